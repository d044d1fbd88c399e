"""The continuation step's figure: the gait family against the parameter and its
multipliers' moduli against the unit level, folds and period doublings marked.

Artists carry ``gid`` s (listed in the docstring) so the tests can read back their data.
"""
from __future__ import annotations

import math

import numpy as np

from ..drawing import Drawing
from ..common import (
    BLACK, BLUE, GREEN, ORANGE, PURPLE, SKY, VERMILLION, count, json_attr, new_figure, style,
)
from ..labels import (
    D1, D2, RATE, SUB, attr_float, complex_of, gait_of, run_line, sci, two_titles, values_of,
)


#: each continuation parameter: axis label, units (mathtext), symbol, name for the title
PARAMETERS = {
    "gravity": ("gravity g", r"[m s$^{-2}$]", "g", "gravity"),
    "com": ("CG of link 1 from end A (link 2's mirrored)", "[m]", "com", "the links' CG "
            "position"),
    "inertia": ("inertia of each link about its CG", r"[kg m$^2$]", "I", "the links' inertia"),
    "torque": ("motor torque (the first motor segment's)", "[N m]", "τ", "motor torque"),
    "mass_ratio": ("mass ratio m2 / m1 (same total mass)", "[1]", "m2/m1", "mass ratio"),
    "joint_viscous": ("viscous friction at the joint", "[N m s]", "b_joint",
                      "joint friction"),
    "pivot_viscous": ("viscous friction at the pivot", "[N m s]", "b_pivot",
                      "pivot friction"),
}


def _int_list(ds, name: str) -> list[int]:
    v = json_attr(ds, name, [])
    try:
        return [int(x) for x in (v if isinstance(v, list) else [v])]
    except (TypeError, ValueError):
        return []


def plot_continuation(ds):
    """A continued gait family against its parameter.

    Panels (shared x, the parameter): ``dtheta1``, ``dtheta2`` [rad s-1] along the branch,
    the swap time [s] (collisionless horizontal family) or the cycle time [s] (a sequence
    gait), and the moduli of the multipliers with the unit level (above it: unstable; a
    sequence gait's neutral multiplier, the free energy level, is left out; log scale when
    they span more than a decade above 10). The branch's first point is ringed; folds (the
    parameter turns back), period doublings (a real multiplier through -1), real multipliers
    through +1 and Neimark-Sacker crossings (a complex pair leaves or enters the unit circle)
    are marked with vertical lines and named in the legend; the subtitle says when there are
    none, and why a sequence branch stopped.

    gids: ``dtheta1``, ``dtheta2``, ``t_switch`` or ``t_cycle`` (x ``parameter_value``),
    ``modulus_<k>`` (y ``|lambda_k|``), ``unit_level``, ``fold_<i>``, ``period_doubling_<i>``,
    ``through_plus_one_<i>``, ``neimark_sacker_<i>``, ``start``.
    """
    mu = values_of(ds, "parameter_value")
    par = str(ds.attrs.get("parameter", "parameter"))
    name, unit, sym, what = PARAMETERS.get(
        par, (par, f"[{ds['parameter_value'].attrs.get('units', '?')}]", par, par))
    sequence = "t_segment" in ds
    lam = complex_of(ds, "multipliers")
    marks_of = [("fold", "folds", SKY, "-.", "fold"),
                ("period_doubling", "period_doublings", BLACK, ":", "period doubling"),
                ("through_plus_one", "through_plus_one", GREEN, "--", "multiplier through +1"),
                ("neimark_sacker", "neimark_sacker", ORANGE, (0, (5, 2, 1, 2)),
                 "Neimark-Sacker")]
    found = {key: _int_list(ds, attr) for key, attr, *_ in marks_of}
    resid = values_of(ds, "residual") if "residual" in ds else np.full(mu.size, np.nan)
    with style():
        fig = new_figure(figsize=(7.6, 9.6))
        marks = [f"{len(found[key])} {label}{'s' if len(found[key]) > 1 else ''}"
                 for key, _a, _c, _l, label in marks_of if found[key]]
        u = unit.strip("[]")
        # a branch that stops at its start (no_branch) is one value, not a range
        values = f"{mu[0]:.6g}" if mu.size == 1 else f"{mu[0]:.6g} → {mu[-1]:.6g}"
        span = (f"{count(mu.size, 'point')}, {sym} = {values}"
                + (f" {u}" if u != "1" else "") if mu.size else "no points")
        ds_step = attr_float(ds, "ds")
        none = ("no folds or bifurcations on this branch" if sequence
                else "no folds or period doublings on this branch")
        # one fact per line: a wrapped line would read as the next fact
        sub = (span + (f" (first arclength step {ds_step:g})" if math.isfinite(ds_step) else "")
               + (f"; max residual {sci(float(np.nanmax(resid)))}"
                  if np.isfinite(resid).any() else "") + "\n"
               + (", ".join(marks) + " (marked)" if marks else none) + "\n")
        if sequence:
            stop = str(ds.attrs.get("stop_reason", ""))
            why = {"steps": "all steps taken", "bounds": "the parameter reached its bound",
                   "border": "the cycle's event sequence changes just ahead (the map jumps)",
                   "ds_min": "the corrector failed at the least step (the map is not smooth "
                             "ahead)"}.get(stop, stop)
            th2 = values_of(ds, "theta2")
            pin = (f"θ2 held at {th2[0]:.4g} rad (a family: one neutral multiplier)"
                   if int(attr_float(ds, "theta2_pinned") or 0) else
                   f"θ2 {th2[0]:.4g} → {th2[-1]:.4g} rad")
            two = attr_float(ds, "steps_per_cycle", 1.0) == 2
            sub += (f"{pin}, from floquet step {ds.attrs.get('floquet_step', '?')}"
                    + ("; a cycle of two steps (the links differ)" if two else "") + "\n"
                    f"stopped: {why}\n" + run_line(ds, tick=False))
            title = f"Sequence-gait family continued in {what}"
        else:
            gait = gait_of(ds)
            sub += (f"from the {gait}\n" if gait else "") + run_line(ds, tick=False, torque=0.0)
            title = f"Collisionless gait family continued in {what}"
        body = two_titles(fig, title, sub)
        axes = body.subplots(4, 1, sharex=True, height_ratios=[1, 1, 1, 1.4])
        if sequence:
            third = ("t_cycle", np.asarray(ds["t_segment"].values, float)[:, -1],
                     "cycle time  [s]")
        else:
            third = ("t_switch", values_of(ds, "t_switch"), "swap time  [s]")
        rows = (("dtheta1", values_of(ds, "dtheta1"), f"{D1}  {RATE}", BLUE),
                ("dtheta2", values_of(ds, "dtheta2"), f"{D2}  {RATE}", BLUE),
                third + (GREEN,))
        for ax, (var, y, lab, c) in zip(axes, rows):
            ax.plot(mu, y, marker="o", ms=3.5, color=c, gid=var)
            ax.plot(mu[:1], y[:1], marker="o", ms=10, mfc="none", mec=BLACK, mew=1.3,
                    ls="none", gid="start" if var == "dtheta1" else f"start_{var}")
            ax.set_ylabel(lab)
            ax.ticklabel_format(axis="y", useOffset=False)
        axl = axes[3]
        mods = np.abs(lam)
        if sequence and mods.ndim == 2 and mods.shape[1]:
            # drop each point's neutral multiplier (the free energy level)
            keep = []
            for row, m in zip(mods, lam):
                d = np.abs(m - 1.0)
                k = int(np.nanargmin(d)) if np.isfinite(d).any() else -1
                keep.append(np.delete(row, k) if k >= 0 and d[k] < 1e-6 else row[:-1])
            mods = np.array(keep)
        colours = [VERMILLION, PURPLE, ORANGE]
        for k in range(mods.shape[1] if mods.ndim == 2 else 0):
            axl.plot(mu, mods[:, k], marker="o", ms=3.5, color=colours[k % 3],
                     gid=f"modulus_{k}", label=f"|λ{k + 1}|")
        axl.axhline(1.0, color="0.2", ls="--", lw=1.1, gid="unit_level",
                    label="|λ| = 1 (above: unstable)")
        axl.set_ylabel("multiplier modulus |λ|  [1]")
        fin = mods[np.isfinite(mods) & (mods > 0)]
        top = float(fin.max()) if fin.size else 1.0
        if top > 10.0:
            axl.set_yscale("log")
            axl.set_ylim(max(float(fin.min()) / 2, 1e-6), top * 2)
        else:
            axl.set_ylim(0, max(1.1, top * 1.1))
        axl.set_xlabel(f"{name}  {unit}")
        axl.ticklabel_format(axis="x", useOffset=False)
        for key, _attr, color, ls, label in marks_of:
            for i in found[key]:
                if key == "fold" and 0 <= i < mu.size:        # the branch turns at a point
                    for a in axes:
                        a.axvline(mu[i], color=color, ls=ls, lw=1.4,
                                  gid=f"{key}_{i}" if a is axl else None)
                    axl.plot([], [], color=color, ls=ls,
                             label=f"{label} at point {i} ({sym} ≈ {mu[i]:.6g})")
                elif 1 <= i < mu.size:          # a crossing lies between two points
                    lo, hi = sorted((mu[i - 1], mu[i]))
                    for a in axes:
                        a.axvspan(lo, hi, color=color, alpha=0.25, lw=0,
                                  gid=f"{key}_{i}" if a is axl else None)
                    axl.fill_between([], [], color=color, alpha=0.25,
                                     label=f"{label} between points {i - 1} and {i} "
                                           f"({sym} from {mu[i - 1]:.6g} to {mu[i]:.6g})")
        handles, labels = axl.get_legend_handles_labels()
        # two columns of long labels (a crossing's span) run off the figure's sides
        body.legend(handles, labels, loc="outside lower center",
                    ncols=2 if max(map(len, labels), default=0) <= 48 else 1, frameon=False)
        if sequence:
            axes[0].set_title("the fixed point along the branch (○: the floquet step's)",
                              loc="left", **SUB)
            axl.set_title("multipliers of the cycle's return map (variational equations; "
                          "the neutral one left out)", loc="left", **SUB)
        else:
            axes[0].set_title("the gait along the branch (○: the shoot's gait)", loc="left",
                              **SUB)
            axl.set_title("open-loop multipliers (motorless map, variational equations)",
                          loc="left", **SUB)
    return fig


#: how the continuation step's figure is drawn
DRAWINGS = {
    ("continuation", "branch"): Drawing(
        title="gait family, |lambda| along it",
        caption="The family's rates against the parameter (top) and the multipliers' moduli along "
                "it (bottom): where a modulus crosses 1 the gait gains or loses stability; folds "
                "and bifurcations are marked.",
        draw=lambda d: plot_continuation(d[0])),
}
