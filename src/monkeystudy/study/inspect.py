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
    elif kind in _ANALYSIS:
        lines += ["    " + x for x in _ANALYSIS[kind](ds, a)]
    return "\n".join(lines)


# --- analysis steps ----------------------------------------------------------------------------
def _complex(ds, name: str) -> np.ndarray:
    return ds[f"{name}_real"].values + 1j * ds[f"{name}_imag"].values


def _mods(lam) -> str:
    return ", ".join(f"{abs(x):.6g}" for x in np.ravel(lam))


def _gait_line(a) -> str:
    if int(a.get("solution", -1)) < 0:
        return "no shoot gait used"
    return (f"gait: solution {a.get('solution')} of {a.get('shoot_step')!r} "
            f"({a.get('gait_method')}), ({float(a['dtheta1']):.10g}, "
            f"{float(a['dtheta2']):.10g}) rad s-1, t_switch {float(a['t_switch']):.6g} s, "
            f"t_motor {float(a['t_motor']):.6g} s, error {float(a['gait_error']):.3g}")


def _shoot(ds, a) -> list[str]:
    from .analysis_tasks import METHOD_NAMES
    out = []
    msgs = json.loads(a.get("message", "[]"))
    for i in range(ds.sizes["solution"]):
        out.append(f"solution {i}{' (best)' if i == int(a.get('best_solution', -1)) else ''}: "
                   f"({float(ds['dtheta1'][i]):.10g}, {float(ds['dtheta2'][i]):.10g}) rad s-1, "
                   f"error {float(ds['error'][i]):.3g}, "
                   f"{METHOD_NAMES[int(ds['method'][i])]}, "
                   f"{'converged' if int(ds['converged'][i]) else 'not converged'}, "
                   f"t_switch {float(ds['t_switch'][i]):.6g} s, t_motor "
                   f"{float(ds['t_motor'][i]):.6g} s, status "
                   f"{STATUS_NAMES[int(ds['status'][i])]}")
        if i < len(msgs):
            out.append(f"  {msgs[i]}")
    fails = json.loads(a.get("failures", "[]"))
    if fails:
        out.append("failed attempts: " + "; ".join(fails))
    out.append(f"starts: {a.get('starts')}")
    return out


def _floquet(ds, a) -> list[str]:
    out = [_gait_line(a)]
    lam, lam_fd = _complex(ds, "multipliers"), _complex(ds, "multipliers_fd")
    for i, c in enumerate(ds["controller"].values):
        fp = ds["fixed_point"].values[i]
        out.append(f"{c}: multipliers {np.array2string(lam[i], precision=6)} (|lambda| "
                   f"{_mods(lam[i])}), {'stable' if int(ds['stable'][i]) else 'unstable'}")
        out.append(f"  finite differences |lambda| {_mods(lam_fd[i])}; agreement "
                   f"{float(ds['agreement'][i]):.2g}; map defect "
                   f"{float(ds['map_defect'][i]):.2g}")
        out.append(f"  fixed point (theta2, dtheta1, dtheta2) = ({fp[0]:.8g}, {fp[1]:.8g}, "
                   f"{fp[2]:.8g}); t_switch {float(ds['t_switch'][i]):.6g} s, t_motor "
                   f"{float(ds['t_motor'][i]):.6g} s")
    return out


def _tick_sweep(ds, a) -> list[str]:
    out = [_gait_line(a),
           f"leading multiplier {float(a.get('leading_multiplier', np.nan)):.6g} "
           f"({a.get('leading_multiplier_source', '')}); error bound "
           f"{a.get('error_bound')}"]
    for i, t in enumerate(ds["tick"].values):
        out.append(f"tick {t:g} s: {int(ds['cycles_to_bound'][i])} cycles to bound, "
                   f"{int(ds['cycles_completed'][i])} completed, status "
                   f"{STATUS_NAMES[int(ds['status'][i])]}, growth per cycle "
                   f"{float(ds['growth_per_cycle'][i]):.4g}")
    return out


def _basin(ds, a) -> list[str]:
    c = ds["cycles"].values
    o1, o2 = ds["d_dtheta1"].values, ds["d_dtheta2"].values
    i0, j0 = int(np.argmin(np.abs(o1))), int(np.argmin(np.abs(o2)))
    return [_gait_line(a),
            f"{c.size} starts, offsets d_dtheta1 {o1[0]:.3g}..{o1[-1]:.3g}, d_dtheta2 "
            f"{o2[0]:.3g}..{o2[-1]:.3g} rad s-1; tick {a.get('tick')} s, error bound "
            f"{a.get('error_bound')}",
            f"cycles: at the least offset ({o1[i0]:.3g}, {o2[j0]:.3g}) {int(c[i0, j0])}, "
            f"min {int(c.min())}, median {float(np.median(c)):g}, max {int(c.max())} of "
            f"{a.get('max_cycles')}"]


def _continuation(ds, a) -> list[str]:
    v = ds["parameter_value"].values
    lam = _complex(ds, "multipliers")
    if "t_segment" in ds:      # a sequence gait: leave the neutral multiplier out
        rest = [np.abs(m[~(np.abs(m - 1.0) < 1e-6)]) for m in lam]
        lead = np.array([r.max() if r.size else np.nan for r in rest])
        th2 = ds["theta2"].values
        head = (f"sequence gait, theta2 {th2[0]:.6g} -> {th2[-1]:.6g} rad (pinned: "
                f"{a.get('theta2_pinned')}), from floquet step {a.get('floquet_step')}; "
                f"stopped: {a.get('stop_reason')}")
        marks = (f"folds {a.get('folds')}, period doublings {a.get('period_doublings')}, "
                 f"through +1 {a.get('through_plus_one')}, Neimark-Sacker "
                 f"{a.get('neimark_sacker')}; stable at {int(ds['stable'].sum())} of "
                 f"{v.size} points")
    else:
        lead = np.abs(lam[:, 0])
        head = _gait_line(a)
        marks = f"folds {a.get('folds')}, period doublings {a.get('period_doublings')}"
    return [head,
            f"{v.size} points, {a.get('parameter')} {v[0]:.8g} -> {v[-1]:.8g} "
            f"{a.get('parameter_units')}; max residual {float(np.nanmax(ds['residual'])):.2g}",
            f"dtheta1 {float(ds['dtheta1'][0]):.8g} -> {float(ds['dtheta1'][-1]):.8g}, dtheta2 "
            f"{float(ds['dtheta2'][0]):.8g} -> {float(ds['dtheta2'][-1]):.8g} rad s-1",
            f"leading |lambda| {lead[0]:.6g} -> {lead[-1]:.6g}; " + marks]


def _work_precision(ds, a) -> list[str]:
    out = [f"{a.get('n_points')} points, reference {a.get('reference')}; "
           f"{a.get('reproducibility', '')}"]
    for i, m in enumerate(ds["method"].values):
        t = ds["time_per_gait"].values[i]
        e = ds["error_value"].values[i]
        cells = ", ".join(f"{r:.0e}: {1e6 * ti:.3g} us / {ei:.2g}"
                          for r, ti, ei in zip(ds["rtol"].values, t, e))
        out.append(f"{m} (rtol: time per gait / error): {cells}")
    for i, m in enumerate(ds["scipy_method"].values):
        t = ds["scipy_time_per_gait"].values[i]
        k = ds["kernel_time_same_points"].values
        cells = ", ".join(f"{r:.0e}: {ti / ki:.3g}x" for r, ti, ki in
                          zip(ds["scipy_rtol"].values, t, k))
        out.append(f"scipy {m} time / kernel dop853 time: {cells}")
    return out


def _stress(ds, a) -> list[str]:
    out = []
    for i, ph in enumerate(ds["drift_phase"].values):
        cells = ", ".join(
            f"{r:.0e}: drift {float(ds['energy_drift'][i, j, -1]):.3g}, exponent "
            f"{float(ds['growth_exponent'][i, j]):.3g}, per period "
            f"{float(ds['drift_per_period'][i, j]):.3g}"
            for j, r in enumerate(ds["drift_rtol"].values))
        out.append(f"energy drift, {ph} (period {float(ds['period'][i]):.4g} s, "
                   f"{float(ds['time'][i, -1]):.4g} s): {cells}")
    for k, r in enumerate(ds["run"].values):
        out.append(f"long run {r}: {STATUS_NAMES[int(ds['run_status'][k])]}, "
                   f"{int(ds['cycles_completed'][k])} of {a.get('cycles')} cycles, "
                   f"{int(ds['steps'][k])} steps, final pivot height "
                   f"{float(ds['final_pivot_height'][k]):.4g} m")
    for k, c in enumerate(ds["case"].values):
        counts = ds["status_counts"].values[k]
        st = ", ".join(f"{STATUS_NAMES[j]} {n}" for j, n in enumerate(counts) if n)
        out.append(f"case {c}: {st}; {'finite where ok' if int(ds['finite_ok'][k]) else 'NON-FINITE'}")
    return out


_ANALYSIS = {"shoot": _shoot, "floquet": _floquet, "tick_sweep": _tick_sweep,
             "basin": _basin, "continuation": _continuation,
             "work_precision": _work_precision, "stress": _stress}
