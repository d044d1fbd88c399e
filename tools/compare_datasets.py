"""Compare two output folders of the same study, dataset by dataset: every variable byte for
byte (``.tobytes()`` of the raw arrays, NaN payloads included) and every global and variable
attribute except the provenance ones, which change with any commit. For a float variable that
differs: how many values, the largest absolute and relative difference.

    python3 tools/compare_datasets.py OUT_A OUT_B

Exit status 0 when every dataset is identical, 1 otherwise.
"""
import sys
from pathlib import Path

import netCDF4
import numpy as np

PROVENANCE = {"monkeystudy_version", "git_revision", "code_sha256", "library_versions",
              "history", "run_key", "created", "elapsed", "step_sha256"}


def attrs(obj) -> dict:
    return {k: obj.getncattr(k) for k in obj.ncattrs() if k not in PROVENANCE}


def same_attr(a, b) -> bool:
    if isinstance(a, str) or isinstance(b, str):
        return a == b
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def compare(pa: Path, pb: Path) -> list[str]:
    """What differs between two datasets (empty: identical)."""
    notes = []
    with netCDF4.Dataset(pa) as A, netCDF4.Dataset(pb) as B:
        A.set_auto_mask(False)
        B.set_auto_mask(False)
        ga, gb = attrs(A), attrs(B)
        for k in sorted(set(ga) | set(gb)):
            if k not in ga or k not in gb or not same_attr(ga[k], gb[k]):
                notes.append(f"attribute {k}: {ga.get(k)!r} vs {gb.get(k)!r}"[:200])
        for v in sorted(set(A.variables) | set(B.variables)):
            if v not in A.variables or v not in B.variables:
                notes.append(f"variable {v} only in {'A' if v in A.variables else 'B'}")
                continue
            x, y = np.asarray(A.variables[v][...]), np.asarray(B.variables[v][...])
            if x.shape != y.shape or x.dtype != y.dtype:
                notes.append(f"{v}: shape/dtype {x.shape} {x.dtype} vs {y.shape} {y.dtype}")
                continue
            if x.dtype.kind in "fc":
                if x.tobytes() != y.tobytes():
                    both = np.isfinite(x) & np.isfinite(y)
                    d = np.abs(x[both] - y[both])
                    r = d / np.maximum(np.abs(x[both]), 1e-300)
                    notes.append(f"{v}: {int(np.sum(x[both] != y[both]))}/{x.size} differ, max "
                                 f"abs {d.max() if d.size else 0:.3g}, max rel "
                                 f"{r.max() if r.size else 0:.3g}, NaN mismatches "
                                 f"{int(np.sum(np.isnan(x) != np.isnan(y)))}")
            elif not np.array_equal(x, y):
                notes.append(f"{v}: {int(np.sum(x != y))}/{x.size} differ")
            va, vb = attrs(A.variables[v]), attrs(B.variables[v])
            if set(va) != set(vb) or not all(same_attr(va[k], vb[k]) for k in va):
                notes.append(f"{v}: variable attributes differ")
    return notes


def main(a_dir: str, b_dir: str) -> int:
    a_dir, b_dir = Path(a_dir), Path(b_dir)
    files = sorted({p.name for p in a_dir.glob("*.nc")} | {p.name for p in b_dir.glob("*.nc")})
    bad = 0
    for name in files:
        pa, pb = a_dir / name, b_dir / name
        if not (pa.exists() and pb.exists()):
            print(f"{name}: only in {'A' if pa.exists() else 'B'}")
            bad += 1
            continue
        notes = compare(pa, pb)
        print(f"{name}: {'IDENTICAL' if not notes else 'DIFFERENT'}")
        for n in notes:
            print(f"   {n}")
        bad += bool(notes)
    print(f"{len(files)} datasets, {bad} different")
    return bad


if __name__ == "__main__":
    sys.exit(1 if main(*sys.argv[1:3]) else 0)
