"""Helpers of the study tests: a small study, and bit-for-bit dataset comparison."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

#: A small study exercising every step kind: a 7 x 9 grid in blocks of 10 points (blocks cut
#: rows), a point-list grid, a two-start refinement from the grid's minima and a stability
#: run of the best one with the run-on clock.
TINY = """\
schema_version: 1
name: tiny
description: small study for the runner tests
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
integrator: {rtol: 1.0e-8, atol: 1.0e-10}
steps:
  - {name: map, kind: grid, block_size: 10,
     dtheta1: {start: 0.0, stop: 2.0, num: 7}, dtheta2: {start: 9.5, stop: 12.5, num: 9}}
  - {name: pts, kind: grid, points: [[0.9, 10.9], [1.0, 11.0], [0.1, 9.0]], block_size: 2}
  - {name: best, kind: refine, start: {from: map, best: 2}, maxiter: 15}
  - {name: cycles, kind: stability, from: best, cycles: 3, controller: {clock: run_on}}
"""

TINY_FILES = ("map.nc", "pts.nc", "best.nc", "cycles.nc")


def write_study(folder: Path, text: str = TINY, name: str = "tiny.yaml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    p = folder / name
    p.write_text(text)
    return p


def assert_same_datasets(a: Path, b: Path, names=None) -> None:
    """Every dataset in folder ``a`` equals its namesake in ``b`` bit for bit (values, dtypes,
    attributes), except the ``history`` attribute (the time of the run).

    Without ``names``, datasets marked ``bit_reproducible = 0`` (work_precision: wall-clock
    timings) are skipped."""
    if names is None:
        names = sorted(p.name for p in Path(a).glob("*.nc") if _reproducible(p))
    assert names, f"no datasets in {a}"
    for name in names:
        with xr.open_dataset(Path(a) / name, engine="netcdf4") as da, \
                xr.open_dataset(Path(b) / name, engine="netcdf4") as db:
            da.load()
            db.load()
        ha, hb = da.attrs.pop("history"), db.attrs.pop("history")
        assert ha and hb
        xr.testing.assert_identical(da, db)
        for v in list(da.variables):
            x, y = np.asarray(da[v].values), np.asarray(db[v].values)
            assert x.dtype == y.dtype, (name, v)
            if x.dtype.kind in "fiu":
                assert x.tobytes() == y.tobytes(), f"{name}:{v} differs"
            else:
                assert np.array_equal(x, y), f"{name}:{v} differs"


def _reproducible(path: Path) -> bool:
    with xr.open_dataset(path, engine="netcdf4") as ds:
        return int(ds.attrs.get("bit_reproducible", 1)) != 0


#: the analysis smoke study (every analysis kind on the seed2009 gait, small budgets)
ANALYSIS_SMOKE = Path(__file__).resolve().parents[2] / "studies" / "analysis_smoke.yaml"


def open_dataset(folder: Path, name: str) -> xr.Dataset:
    """Dataset ``name`` of a study output ``folder``, loaded and closed."""
    with xr.open_dataset(Path(folder) / name) as ds:
        return ds.load()
