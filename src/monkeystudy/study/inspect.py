"""Readable summaries of study datasets: one dataset (``monkeystudy inspect FILE.nc``: its
provenance, dimensions and variables, and the key numbers its step kind reports,
:meth:`~monkeystudy.study.steps.base.StepKind.describe`), or a study's output folder
(``monkeystudy inspect FOLDER``: the key numbers of each of its datasets, in the study's step
order)."""
from __future__ import annotations

import json
from pathlib import Path

from .failures import FAILED, read_failures
from .progress import singular_counts
from .steps import REGISTRY

_SHOWN_ATTRS = ("study_name", "step_name", "step_kind", "study_sha256", "monkeystudy_version",
                "git_revision", "history")


def summarize(path: Path) -> str:
    """The summary of the dataset at ``path``, as lines of text."""
    # xarray loads in ~0.5 s: only this command pays for it
    import xarray as xr

    with xr.open_dataset(path, engine="netcdf4") as ds:
        ds.load()
    a = ds.attrs
    lines = [f"{path}"]
    for k in _SHOWN_ATTRS:
        if k in a:
            lines.append(f"  {k}: {a[k]}")
    for k in ("robot", "gait", "integrator"):
        if k in a:
            try:
                lines.append(f"  {k}: {json.dumps(json.loads(a[k]), sort_keys=True)}")
            except (TypeError, ValueError):
                lines.append(f"  {k}: {a[k]}")
    lines.append("  dims: " + ", ".join(f"{d}={n}" for d, n in ds.sizes.items()))
    lines.append("  variables:")
    for name in list(ds.coords) + list(ds.data_vars):
        v = ds[name]
        dims = f"({', '.join(v.dims)})" if v.dims else "()"
        lines.append(f"    {name}{dims} {v.dtype} [{v.attrs.get('units', '-')}]: "
                     f"{v.attrs.get('long_name', '')}")
    kind = REGISTRY.get(a.get("step_kind"))
    lines.append("  summary:")
    if kind is not None:
        lines += ["    " + singular_counts(x) for x in kind.describe(ds)]
    return "\n".join(lines)


class NoDatasets(ValueError):
    """A folder that holds no study dataset."""


def study_files(folder: Path) -> list[tuple[Path, dict]]:
    """The study datasets in ``folder`` (``*.nc`` with a known ``step_kind``; hidden and
    temporary files skipped) with their global attributes, in the order of the steps of the
    study that wrote them (then by name)."""
    import xarray as xr  # loads in ~0.5 s: only inspect pays for it

    found = []
    for p in sorted(Path(folder).glob("*.nc")):
        if p.name.startswith("."):
            continue
        try:
            with xr.open_dataset(p, engine="netcdf4") as ds:
                attrs = dict(ds.attrs)
        except (OSError, ValueError):
            continue
        if attrs.get("step_kind") in REGISTRY:
            found.append((p, attrs))

    def position(item) -> tuple:
        path, attrs = item
        order = step_order(attrs.get("study_text", ""))
        name = attrs.get("step_name", path.stem)
        return (order.index(name) if name in order else len(order), path.name)

    return sorted(found, key=position)


def step_order(study_text: str) -> list[str]:
    """The step names of a study file's text, in order (empty if it cannot be read)."""
    from ruamel.yaml import YAML, YAMLError  # only a folder's summary parses study texts

    try:
        data = YAML(typ="safe").load(study_text)
        return [str(s["name"]) for s in data["steps"]]
    except (YAMLError, TypeError, KeyError, AttributeError):
        return []


def summarize_folder(folder: Path) -> str:
    """The key numbers of every study dataset in ``folder``, a few lines each, and every step
    of its last run that wrote no dataset, with the reason (its failure marker)."""
    import xarray as xr  # loads in ~0.5 s: only inspect pays for it

    files = study_files(folder)
    failures = read_failures(folder)
    if not files and not failures:
        below = sorted({p.parent for p in Path(folder).glob("*/*.nc")
                        if not p.name.startswith(".")})
        msg = f"{folder}: no study datasets here (the *.nc files 'monkeystudy run' writes)"
        if below:
            msg += "; folders below it with datasets: " + ", ".join(str(b) for b in below)
        raise NoDatasets(msg)
    studies = sorted({a.get("study_name", "?") for _, a in files}
                     | {f.study_name for f in failures.values()})
    lines = [f"{folder}: {len(files)} dataset{'s' if len(files) != 1 else ''} of study "
             f"{', '.join(repr(s) for s in studies)}"]
    for path, attrs in files:
        with xr.open_dataset(path, engine="netcdf4") as ds:
            ds.load()
        lines.append(f"  {path.name} [{attrs['step_kind']}]")
        kind = REGISTRY[attrs["step_kind"]]
        lines += ["    " + singular_counts(x) for x in kind.describe(ds)]
    if failures:
        n = len(failures)
        lines.append(f"{n} step{'s' if n != 1 else ''} of the last run wrote no dataset:")
        for f in failures.values():
            what = "failed" if f.state == FAILED else "not run"
            lines.append(f"  {f.step} [{f.kind}] {what}: {f.reason}")
    if files:
        lines.append(f"(variables and provenance of one dataset: monkeystudy inspect "
                     f"{files[0][0]})")
    return "\n".join(lines)
