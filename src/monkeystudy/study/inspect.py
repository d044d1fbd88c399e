"""A readable summary of a study dataset (``monkeystudy inspect FILE.nc``)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..kernel.layout import STATUS_NAMES

_SHOWN_ATTRS = ("study_name", "step_name", "step_kind", "study_sha256", "monkeystudy_version",
                "git_revision", "history")


def _status_counts(status: np.ndarray) -> str:
    vals, counts = np.unique(np.asarray(status).ravel(), return_counts=True)
    parts = []
    for v, c in zip(vals, counts):
        name = STATUS_NAMES[int(v)] if 0 <= int(v) < len(STATUS_NAMES) else str(v)
        parts.append(f"{name} {c} ({100.0 * c / status.size:.1f}%)")
    return ", ".join(parts)


def summarize(path: Path) -> str:
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
    kind = a.get("step_kind")
    lines.append("  summary:")
    if kind == "grid":
        lines.append(f"    points: {int(ds['status'].size)}, skipped_fraction "
                     f"{float(a.get('skipped_fraction', np.nan)):.3f}")
        lines.append(f"    status: {_status_counts(ds['status'].values)}")
        err = ds["error"].values
        if np.isfinite(err).any():
            k = int(np.nanargmin(err))
            if ds["error"].ndim == 2:
                i, j = np.unravel_index(k, err.shape)
                d1, d2 = float(ds["dtheta1"][i]), float(ds["dtheta2"][j])
            else:
                d1, d2 = float(ds["dtheta1"][k]), float(ds["dtheta2"][k])
            lines.append(f"    least error {np.nanmin(err):.4g} at dtheta1 = {d1:.6g}, "
                         f"dtheta2 = {d2:.6g} rad s-1")
        else:
            lines.append("    no point with an error value")
    elif kind == "refine":
        d1, d2 = np.atleast_1d(ds["dtheta1"].values), np.atleast_1d(ds["dtheta2"].values)
        err = np.atleast_1d(ds["error"].values)
        st = np.atleast_1d(ds["status"].values)
        conv = np.atleast_1d(ds["converged"].values)
        nit = np.atleast_1d(ds["nit"].values)
        for k in range(d1.size):
            lines.append(f"    start {k}: ({float(np.atleast_1d(ds['start_dtheta1'].values)[k]):.6g}, "
                         f"{float(np.atleast_1d(ds['start_dtheta2'].values)[k]):.6g}) -> "
                         f"({d1[k]:.6g}, {d2[k]:.6g}) rad s-1, error {err[k]:.4g}, "
                         f"{STATUS_NAMES[int(st[k])]}, {'converged' if conv[k] else 'stopped'}"
                         f" after {int(nit[k])} iterations")
        lines.append(f"    t_switch {np.atleast_1d(ds['t_switch'].values)[0]:.6g} s, t_motor "
                     f"{np.atleast_1d(ds['t_motor'].values)[0]:.6g} s (first start)")
        lines.append(f"    message: {a.get('message', '')}")
    elif kind == "stability":
        err = ds["error"].values
        n_ok = int(np.isfinite(err).sum())
        lines.append(f"    status {STATUS_NAMES[int(ds['status'])]}, "
                     f"{a.get('cycles_completed', '?')} of {err.size} cycles completed, "
                     f"{n_ok} vertical crossings")
        if n_ok:
            lines.append(f"    error: first {err[0]:.4g}, last {err[np.isfinite(err)][-1]:.4g}")
            ph = ds["pivot_height"].values
            lines.append(f"    pivot height: first {ph[0]:.4g} m, last "
                         f"{ph[np.isfinite(ph)][-1]:.4g} m")
        lines.append(f"    replayed t_switch {a.get('t_switch')} s, t_motor {a.get('t_motor')} "
                     f"s, controller {a.get('controller')}")
    return "\n".join(lines)
