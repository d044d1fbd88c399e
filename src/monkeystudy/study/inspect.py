"""A readable summary of a study dataset (``monkeystudy inspect FILE.nc``): its provenance,
dimensions and variables, and the key numbers its step kind reports
(:meth:`~monkeystudy.study.steps.base.StepKind.describe`)."""
from __future__ import annotations

import json
from pathlib import Path

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
        lines += ["    " + x for x in kind.describe(ds)]
    return "\n".join(lines)
