"""Figures of the analysis datasets (docs/datasets.md, "Analysis steps").

One figure per dataset, each a :class:`matplotlib.figure.Figure` in the package style:

* :func:`plot_shoot_convergence` (``shoot``) - residual norm per Newton iteration, one line
  per solution, and ``r[k+1]`` against ``r[k]`` with a slope-2 line (quadratic convergence);
* :func:`plot_floquet_multipliers` (``floquet``) - the multipliers in the complex plane with
  the unit circle, variational equations (filled) against finite differences (open), one
  panel per controller;
* :func:`plot_tick_sweep` (``tick_sweep``) - error per cycle for each controller tick, with
  the growth ``|lambda_max|^(2n)`` the leading multiplier predicts: the "was it the 1 ms
  grid?" figure;
* :func:`plot_basin` (``basin``) - cycles to failure over start offsets around the gait;
* :func:`plot_continuation` (``continuation``) - the gait family against the parameter and
  its multipliers' moduli against the unit level, folds and period doublings marked;
* :func:`plot_work_precision` (``work_precision``) - wall time per gait against error for
  each integrator and tolerance, scipy beside the kernel.

:data:`DRAWINGS` registers each under the ``(step kind, suffix)`` its kind declares;
:func:`monkeystudy.plotting.report.plan` draws them for every such dataset of a study.
Artists carry ``gid`` s (listed in each docstring) so the tests can read back their data.
"""
from __future__ import annotations

import json
import math
import re
import textwrap

import matplotlib
import numpy as np
from matplotlib.colors import BoundaryNorm
from matplotlib.lines import Line2D
from matplotlib.patches import Circle
from matplotlib.patheffects import withStroke
from matplotlib.ticker import MaxNLocator

from .drawing import Drawing, NothingToDraw
from .common import (
    BLACK, BLUE, ERROR_UNITS, GREEN, ORANGE, PURPLE, SKY, VERMILLION, count, fmt_tick,
    gait_settings, json_attr, new_figure, robot_name, status_name, style,
)
from ..kernel import layout as L

D1 = r"$\dot\theta_1$"
D2 = r"$\dot\theta_2$"
RATE = r"[rad s$^{-1}$]"
#: multipliers this close to 1 are neutral (the datasets' ``neutral_tol`` when present)
NEUTRAL_TOL = 1e-6
SUB = dict(fontsize=8.5, fontweight="normal")

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
CONTROLLERS = {
    "open_loop": "open-loop replay of the recorded times",
    "search": "state-based search controller",
}
SHOOT_METHODS = ("Gauss-Newton", "grazing")


# ----------------------------------------------------------------------------------------------
# shared pieces
# ----------------------------------------------------------------------------------------------
def attr_float(ds, name: str, default=math.nan) -> float:
    try:
        return float(ds.attrs[name])
    except (KeyError, TypeError, ValueError):
        return default


def values_of(ds, name: str) -> np.ndarray:
    return np.asarray(ds[name].values, dtype=float)


def _complex(ds, name: str) -> np.ndarray:
    return values_of(ds, f"{name}_real") + 1j * values_of(ds, f"{name}_imag")


def run_line(ds, *, tick: bool = True, torque: float | None = None,
             integrator: bool = True) -> str:
    """What was run, in one line: robot, motor torque (``torque`` overrides the study's, e.g.
    0 for a motorless replay), controller tick (``tick=False``: the figure sweeps or fixes it
    itself), integrator, study / step."""
    g = gait_settings(ds)
    parts = [f"robot {robot_name(ds)}"]
    if torque is not None:
        parts.append(f"τ = {torque:g} N m" if torque else "no motor torque")
    elif "motor_torque" in g:
        parts.append(f"τ = {float(g['motor_torque']):g} N m")
    if tick and "tick" in g:
        parts.append(fmt_tick(g["tick"]))
    integ = json_attr(ds, "integrator", {})
    if integrator and isinstance(integ, dict) and "method" in integ:
        s = str(integ["method"]).upper()
        if "rtol" in integ:
            s += f" rtol {float(integ['rtol']):.0e}"
        parts.append(s)
    study, step = ds.attrs.get("study_name"), ds.attrs.get("step_name")
    if study or step:
        parts.append(f"study {study or '?'}" + (f" / {step}" if step else ""))
    return ", ".join(parts)


def _gait_of(ds) -> str | None:
    """``gait (dtheta1, dtheta2) rad s-1`` from a dataset's gait attributes, or None."""
    d1, d2 = attr_float(ds, "dtheta1"), attr_float(ds, "dtheta2")
    if not (math.isfinite(d1) and math.isfinite(d2)):
        return None
    th2 = attr_float(ds, "start_theta2")
    if math.isfinite(th2):                       # a sequence gait: its section state
        s = f"gait (θ2 {th2:.3g} rad; {d1:.6g}, {d2:.6g} rad s⁻¹)"
        for key, what in (("floquet_step", "fixed point of floquet step"),
                          ("refine_step", "start of refine step")):
            if ds.attrs.get(key):
                return f"{s}, {what} {ds.attrs[key]}"
        return s
    s = f"gait ({d1:.6g}, {d2:.6g}) rad s⁻¹"
    src = ds.attrs.get("shoot_step")
    return f"{s} from shoot step {src}" if src else s


def _times_of(ds) -> str:
    ts, tm = attr_float(ds, "t_switch"), attr_float(ds, "t_motor")
    if not math.isfinite(ts):
        return ""
    s = f"swap at {ts:.4g} s"
    if math.isfinite(tm):
        s += ", no motor phase" if tm == 0 else f", motor {tm:.4g} s"
    return s


def _visible_len(word: str) -> int:
    """Characters ``word`` shows once drawn (mathtext ``$...$`` counted by its glyphs)."""
    def glyphs(m):
        inner = re.sub(r"\\[a-zA-Z]+", "x", m.group(0)[1:-1])
        return "x" * len(re.sub(r"[{}^_]", "", inner))
    return len(re.sub(r"\$[^$]*\$", glyphs, word))


def _wrap(text: str, width: int) -> str:
    """Greedy word wrap of each line of ``text`` to ``width`` visible characters."""
    out = []
    for line in text.split("\n"):
        cur, n = [], 0
        for w in line.split(" "):
            k = _visible_len(w)
            if cur and n + 1 + k > width:
                out.append(" ".join(cur))
                cur, n = [], 0
            n += k + (1 if cur else 0)
            cur.append(w)
        out.append(" ".join(cur))
    return "\n".join(out)


def two_titles(fig, title: str, subtitle: str):
    """Bold title and a smaller subtitle (what was run) above every panel, wrapped to the
    figure's width; returns the subfigure the panels go in."""
    usable = fig.get_figwidth() * 72.0 * 0.93          # [pt]
    fig.suptitle(_wrap(title, int(usable / 6.9)), x=0.02, ha="left", fontweight="bold")
    body = fig.subfigures(1, 1)
    body.suptitle(_wrap(subtitle, int(usable / 4.8)), x=0.02, ha="left", **SUB)
    return body


def sci(x: float, digits: int = 2) -> str:
    """Short scientific text: ``4.9e-27``; ``0``; ``nan`` as a dash."""
    if not math.isfinite(x):
        return "–"
    if x == 0:
        return "0"
    return f"{x:.{digits - 1}e}".replace("e-0", "e-").replace("e+0", "e+")


def _positive(y) -> np.ndarray:
    """Values for a log axis: non-positive and non-finite ones masked."""
    y = np.asarray(y, float)
    return np.ma.masked_where(~np.isfinite(y) | (y <= 0), y)


OUTLINE = [withStroke(linewidth=2.5, foreground="white")]


# ----------------------------------------------------------------------------------------------
# shoot
# ----------------------------------------------------------------------------------------------
def quadratic_constant(history, floor: float) -> float:
    """``C`` of the quadratic model ``r[k+1] = C r[k]^2`` fitted to a Newton history: the
    median of ``r[k+1] / r[k]^2`` over the steps that end above ``floor`` (round-off) and
    start below 1 (the local regime); NaN when there is no such step."""
    h = np.asarray(history, float)
    h = h[np.isfinite(h)]
    a, b = h[:-1], h[1:]
    ok = (a > 0) & (a < 1) & (b > floor)
    return float(np.median(b[ok] / a[ok] ** 2)) if ok.any() else math.nan


def plot_shoot_convergence(ds):
    """Newton shooting: residual norm per iteration (log scale), one line per solution.

    Left: ``history`` against the iteration, each line ending in a marker annotated with the
    solution's gait error ``e``; the Newton tolerance dotted. Right: ``r[k+1]`` against
    ``r[k]`` (log-log): quadratic convergence puts the points on a line of slope 2 (dashed,
    ``r[k+1] = C r[k]^2`` with ``C`` fitted on the converged solutions), no progress on the
    diagonal (slope 1).

    gids: ``history_<i>`` (x: iterations with data, y: ``history[i]``), ``final_<i>`` (the
    annotation), ``ratio_<i>`` (x ``r[:-1]``, y ``r[1:]``), ``quadratic_guide``,
    ``linear_guide``, ``tol``.
    """
    hist = values_of(ds, "history")
    n_sol = hist.shape[0]
    it = np.asarray(ds["iteration"].values, float) if "iteration" in ds.coords \
        else np.arange(hist.shape[1], dtype=float)
    err = values_of(ds, "error")
    res = values_of(ds, "residual_norm") if "residual_norm" in ds else np.full(n_sol, np.nan)
    conv = values_of(ds, "converged") if "converged" in ds else np.zeros(n_sol)
    meth = values_of(ds, "method").astype(int) if "method" in ds else np.zeros(n_sol, int)
    d1, d2 = values_of(ds, "dtheta1"), values_of(ds, "dtheta2")
    tol = attr_float(ds, "tol")
    floor = 10.0 * tol if math.isfinite(tol) else 1e-13
    colours = [BLUE, VERMILLION, GREEN, PURPLE, ORANGE, SKY, BLACK]
    with style():
        fig = new_figure(figsize=(10.0, 5.6))
        starts = json_attr(ds, "starts", [])
        n_starts = len(starts) if isinstance(starts, list) else 0
        sub = (f"{n_sol} solution{'s' if n_sol != 1 else ''}"
               + (f" from {n_starts} start{'s' if n_starts != 1 else ''}" if n_starts else "")
               + "; grazing: Newton on B at A's height at rest (collisionless swap); "
                 "Gauss-Newton: on the gait's repeatability residual; e: the gait error "
                 "(docs/model.md section 4) of the solution\n"
                 "Quadratic convergence: the number of correct digits doubles per iteration "
                 "(right: points on the slope-2 line)\n"
               + run_line(ds, tick=False))
        body = two_titles(fig, "Newton shooting for exact gaits: residual norm per iteration", sub)
        ax, axr = body.subplots(1, 2, width_ratios=[1.5, 1.0])
        handles = []
        cs = []
        for i in range(n_sol):
            c = colours[i % len(colours)]
            h = hist[i]
            keep = np.isfinite(h)
            x, y = it[keep], h[keep]
            ax.plot(x, _positive(y), marker="o", ms=3.5, color=c, gid=f"history_{i}")
            m = SHOOT_METHODS[meth[i]] if 0 <= meth[i] < len(SHOOT_METHODS) else "?"
            state = (f"converged in {count(y.size - 1, 'iteration')}" if conv[i] == 1
                     else f"not converged, stopped after {y.size - 1}")
            handles.append(Line2D([], [], color=c, marker="o", ms=3.5, label=(
                f"solution {i}: {m}, {state}: ({d1[i]:.6f}, {d2[i]:.6f}) rad s⁻¹, "
                f"|r| = {sci(res[i])}, e = {sci(err[i])}")))
            if y.size:
                ax.plot(x[-1], y[-1], marker="o", ms=8, mfc="none", mec=c, mew=1.5, ls="none")
                ax.annotate(f"e = {sci(err[i])}", (x[-1], y[-1]), xytext=(6, 6 if i % 2 == 0
                                                                              else -14),
                            textcoords="offset points", fontsize=8.5, color=c,
                            path_effects=OUTLINE, gid=f"final_{i}")
            if y.size > 1:
                axr.plot(y[:-1], y[1:], marker="o", ms=4, ls="-", lw=0.8, color=c,
                         gid=f"ratio_{i}")
            if conv[i] == 1:
                cs.append(quadratic_constant(y, floor))
        if math.isfinite(tol):
            ax.axhline(tol, color="0.4", ls=":", lw=1.0, gid="tol")
            handles.append(Line2D([], [], color="0.4", ls=":", label=f"Newton tolerance "
                                                                     f"{sci(tol, 1)}"))
        ax.set_yscale("log")
        ax.set_xlabel("Newton iteration (0: the start)")
        ax.set_ylabel("residual norm |r|  [1]")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_title("residual norm per iteration", loc="left", **SUB)

        # r[k+1] against r[k]: slope 2 = quadratic
        r = hist[np.isfinite(hist) & (hist > 0)]
        if r.size:
            lo, hi = r.min() / 3, max(r.max() * 3, 1e-12)
            xs = np.geomspace(lo, hi, 50)
            fitted = bool(cs) and bool(np.isfinite(cs).any())
            C = float(np.nanmedian(cs)) if fitted else 1.0
            axr.plot(xs, C * xs ** 2, ls="--", color="0.25", lw=1.0, gid="quadratic_guide")
            axr.plot(xs, xs, ls=":", color="0.55", lw=1.0, gid="linear_guide")
            handles += [Line2D([], [], ls="--", color="0.25",
                               label=f"quadratic: r[k+1] = {C:.2g}·r[k]² (slope 2; " + (
                                   "C fitted on the converged solutions)" if fitted
                                   else "no converged solution to fit C)")),
                        Line2D([], [], ls=":", color="0.55",
                               label="r[k+1] = r[k]: no progress (slope 1)")]
            axr.set_xlim(lo, hi)
            axr.set_ylim(lo, hi)
        axr.set_xscale("log")
        axr.set_yscale("log")
        axr.set_box_aspect(1.0)                 # equal ranges in a square: slopes read true
        axr.set_xlabel("residual norm r[k]  [1]")
        axr.set_ylabel("next residual norm r[k+1]  [1]")
        axr.set_title("order of convergence", loc="left", **SUB)
        body.legend(handles=handles, loc="outside lower center", ncols=1, frameon=False)
    return fig


# ----------------------------------------------------------------------------------------------
# floquet
# ----------------------------------------------------------------------------------------------
def _classify(lam: np.ndarray, neutral_tol: float) -> list[str]:
    out = []
    for v in lam:
        if abs(v - 1.0) < neutral_tol:
            out.append("neutral")
        elif abs(v) > 1.0:
            out.append("unstable")
        else:
            out.append("stable")
    return out


CLASS_COLOUR = {"unstable": VERMILLION, "stable": BLUE, "neutral": "0.45"}


def _section_of(ds) -> float:
    """The return map's section theta1 [rad]: the gait's section, the vertical by default."""
    try:
        g = json.loads(ds.attrs.get("gait", "{}"))
    except (TypeError, ValueError):
        return 0.0
    return float(g.get("section", {}).get("theta1", 0.0))


def _cycle_of(ds) -> str:
    """What one cycle of a sequence gait's fixed point does (advance, climb, duration)."""
    if "x_advance" not in ds:
        return ""
    parts = [f"cycle: x advance {float(ds['x_advance'].values[0]):.4g} m",
             f"climb {float(ds['y_advance'].values[0]):.3g} m"]
    if "t_segment" in ds:
        parts.append(f"period {float(np.asarray(ds['t_segment'].values)[0, -1]):.4g} s")
    return ", ".join(parts) + "\n"


def _label_offsets(lam: np.ndarray, R: float) -> list[int]:
    """Vertical offsets [points] of the ``|lambda|`` labels: above a multiplier (below one in
    the lower half plane), moved to the other side or one more row out wherever a label already
    sits within 0.3 R horizontally on that row (a near-real complex pair beside a real
    multiplier would otherwise print three labels on top of each other)."""
    taken: list[tuple[float, int]] = []
    out = []
    for v in lam:
        prefer = -1 if v.imag < -1e-12 else 1
        for row in (prefer, -prefer, 2 * prefer, -2 * prefer, 3 * prefer, -3 * prefer):
            if not any(r == row and abs(v.real - x) < 0.3 * R for x, r in taken):
                break
        taken.append((v.real, row))
        out.append(11 + 12 * (row - 1) if row > 0 else -16 - 12 * (-row - 1))
    return out


def _multiplier_panel(ax, lam, fd, ntol: float, R: float, tag: str, neutral_what: str):
    """One set of multipliers ``lam`` (filled, coloured by class) and ``fd`` (open circles,
    or None) in the complex plane with the unit circle, each labelled with its modulus; gids
    ``<tag>`` ... as :func:`plot_floquet_multipliers` names them (``tag`` = ``multipliers_<c>``
    or ``full_multipliers_<c>``). Returns the multipliers' classes."""
    c = tag.split("multipliers_", 1)[1]
    prefix = tag.split("multipliers_", 1)[0]
    cls = _classify(lam, ntol)
    ax.add_patch(Circle((0, 0), 1.0, fill=False, color="0.3", lw=1.2, ls="-",
                        gid=f"{prefix}unit_circle_{c}"))
    ax.axhline(0, color="0.7", lw=0.7, zorder=0)
    ax.axvline(0, color="0.7", lw=0.7, zorder=0)
    if fd is not None:
        ax.scatter(fd.real, fd.imag, s=150, facecolors="none", edgecolors="black",
                   linewidths=1.2, zorder=4, gid=f"{prefix}multipliers_fd_{c}")
    ax.scatter(lam.real, lam.imag, s=45, c=[CLASS_COLOUR[k] for k in cls],
               edgecolors="black", linewidths=0.6, zorder=5, gid=tag)
    for k, (v, kind, dy) in enumerate(zip(lam, cls, _label_offsets(lam, R))):
        txt = f"|λ| = {abs(v):.4g}" + (f" ({neutral_what})" if kind == "neutral" else "")
        ax.annotate(txt, (v.real, v.imag), xytext=(0, dy), textcoords="offset points",
                    ha="center", fontsize=8,
                    color=CLASS_COLOUR[kind] if kind != "neutral" else "0.3",
                    path_effects=OUTLINE, zorder=6, gid=f"{prefix}modulus_{c}_{k}")
    ax.set_xlim(-R, R)                  # a square box with equal ranges: equal scales
    ax.set_ylim(-R, R)
    ax.set_box_aspect(1.0)
    ax.set_xlabel("Re λ  [1]")
    ax.set_ylabel("Im λ  [1]")
    return cls


def plot_floquet_multipliers(ds):
    """Floquet multipliers in the complex plane, one panel per controller.

    The unit circle is the stability boundary. Filled dots: multipliers by variational
    equations; open circles: by finite differences (they coincide when both are right).
    Colours: outside the circle (unstable), inside (stable), neutral (within ``neutral_tol``
    of 1: the energy level of the state-based controller, excluded from stability). Each
    multiplier is labelled with ``|lambda|``; each panel says stable / unstable. A dataset
    that analysed the full map (attribute ``height_in_map``) has a second row: the full
    map's multipliers, the attached end's height included (a neutral height is not stable).

    gids per controller ``c``: ``multipliers_<c>`` (PathCollection, offsets (Re, Im)),
    ``multipliers_fd_<c>``, ``unit_circle_<c>``, ``modulus_<c>_<k>`` (the labels); the full
    map's the same with the prefix ``full_``.
    """
    ctrls = [str(c) for c in np.atleast_1d(ds["controller"].values)]
    failures = ([str(f) for f in np.atleast_1d(ds["failure"].values)] if "failure" in ds
                else [""] * len(ctrls))
    if all(failures):
        raise NothingToDraw("no return map was analysed: " + "; ".join(
            f"{c}: {f}" for c, f in zip(ctrls, failures)))
    full = bool(int(ds.attrs.get("height_in_map", 0))) and "full_multipliers_real" in ds
    lam_all = _complex(ds, "multipliers")
    fd_all = _complex(ds, "multipliers_fd") if "multipliers_fd_real" in ds else None
    full_all = _complex(ds, "full_multipliers") if full else None
    full_fd_all = _complex(ds, "full_multipliers_fd") if full else None
    ntol = attr_float(ds, "neutral_tol", NEUTRAL_TOL)
    n = len(ctrls)
    rows = 2 if full else 1
    with style():
        fig = new_figure(figsize=(max(7.0, 4.4 * n + 0.6), 6.8 + 5.2 * (rows - 1)))
        gait = _gait_of(ds)
        times = _times_of(ds)
        section = _section_of(ds)
        if "sequence" in ctrls:
            what = (f"sequence gait, refined start {gait}\n" if gait else "") + \
                _cycle_of(ds)
        else:
            what = (f"open loop: {gait}" + (f", {times}" if times else "") + "\n"
                    if gait else "")
        state = (r"($\theta_2$, " + D1 + ", " + D2 + ")" + (
            r"; below, the full map: the state with y, the attached end's height relative to "
            "the start" if full else ""))
        sub = (rf"Return map P on the section $\theta_1$ = {section:.4g} rad, state "
               + state + "; a multiplier outside the unit circle makes the gait unstable\n"
               + what + run_line(ds, tick=False))
        body = two_titles(fig, "Floquet multipliers of the gait's return map", sub)
        grid = body.subplots(rows, n, squeeze=False)
        axes = np.atleast_1d(grid[0])
        finite = np.abs(np.concatenate([lam_all[np.isfinite(lam_all)]] + (
            [full_all[np.isfinite(full_all)]] if full else [])))
        R = max(1.2, 1.18 * float(finite.max()) if finite.size else 1.2)   # one scale
        for j, (ax, c) in enumerate(zip(axes, ctrls)):
            if failures[j]:
                for axj in grid[:, j]:
                    axj.set_axis_off()
                ax.set_title(f"{CONTROLLERS.get(c, c)}: NOT ANALYSED", loc="left",
                             fontsize=8.5, fontweight="normal", color=VERMILLION)
                ax.text(0.0, 0.9, textwrap.fill(failures[j], 48), transform=ax.transAxes,
                        va="top", fontsize=8.5, gid=f"failure_{c}")
                continue
            lam = lam_all[j]
            cls = _multiplier_panel(ax, lam, None if fd_all is None else fd_all[j], ntol, R,
                                    f"multipliers_{c}", "neutral")
            stable = bool(int(ds["stable"].values[j])) if "stable" in ds else \
                all(k != "unstable" for k in cls)
            others = [abs(v) for v, k in zip(lam, cls) if k != "neutral"]
            lead = max(others) if others else math.nan
            verdict = "STABLE" if stable else "UNSTABLE"
            lines = [f"{CONTROLLERS.get(c, c)}: {verdict}",
                     f"largest |λ| = {lead:.4g}" + (" (neutral λ = 1 excluded)"
                                                    if "neutral" in cls else "")]
            if "agreement" in ds:
                lines.append(f"var. eq. vs finite diff.: max|ΔJ| / max|J| = "
                             f"{sci(float(ds['agreement'].values[j]))}")
            if "fixed_point" in ds:
                z = values_of(ds, "fixed_point")[j]
                lines.append(rf"fixed point $\theta_2$ = {z[0]:.4g} rad, {D1} = {z[1]:.4g}, "
                             f"{D2} = {z[2]:.4g} rad s⁻¹")
            ax.set_title("\n".join(lines), loc="left", fontsize=8.5,
                         fontweight="normal", color=VERMILLION if not stable else BLACK)
            if full:
                axf = grid[1, j]
                _multiplier_panel(axf, full_all[j], full_fd_all[j], ntol, R,
                                  f"full_multipliers_{c}", "neutral: the height")
                ok = bool(int(ds["full_stable"].values[j]))
                rho = float(ds["full_spectral_radius"].values[j])
                rho_fd = float(ds["full_spectral_radius_fd"].values[j])
                height = float(values_of(ds, "full_jacobian")[j][0, 0])
                axf.set_title("\n".join([
                    f"full map (y, θ2, {D1}, {D2}): {'STABLE' if ok else 'NOT STABLE'}"
                    + ("" if ok else " (height included)"),
                    f"spectral radius {rho:.10g} (finite differences {rho_fd:.10g})",
                    f"var. eq. vs finite diff.: max|ΔJ| / max|J| = "
                    f"{sci(float(ds['full_agreement'].values[j]))}",
                    f"height: dy'/dy = {height:.3g}"]), loc="left", fontsize=8.5,
                    fontweight="normal", color=BLACK if ok else VERMILLION)
        handles = [
            Line2D([], [], marker="o", ls="none", mfc="0.6", mec="black", ms=7,
                   label="variational equations (saltation matrices at the events)"),
            Line2D([], [], marker="o", ls="none", mfc="none", mec="black", ms=12, mew=1.2,
                   label="finite differences of the return map"),
            Line2D([], [], marker="o", ls="none", mfc=VERMILLION, mec="black", ms=7,
                   label="|λ| > 1: unstable"),
            Line2D([], [], marker="o", ls="none", mfc=BLUE, mec="black", ms=7,
                   label="|λ| < 1: stable"),
            Line2D([], [], marker="o", ls="none", mfc="0.45", mec="black", ms=7,
                   label=f"neutral, |λ − 1| < {sci(ntol, 1)} (the energy level"
                         + ("; the height" if full else "") + ")"),
            Line2D([], [], color="0.3", label="unit circle |λ| = 1"),
        ]
        body.legend(handles=handles, loc="outside lower center", ncols=2 if n > 1 else 1,
                    frameon=False)
    return fig


# ----------------------------------------------------------------------------------------------
# tick sweep
# ----------------------------------------------------------------------------------------------
def prediction_anchor(error, lam: float, window=(1e-20, 1e-8)) -> tuple[float, np.ndarray]:
    """``c`` of the predicted growth ``error[n] = c * lam^(2n)`` (n = 1, 2, ...) fitted to an
    error series over its linear regime (``window[0] < error < window[1]``: above round-off,
    below the nonlinear range); returns ``(c, mask of the cycles used)``. When no cycle lies
    in the window, the smallest positive error is used; NaN when there is none."""
    e = np.asarray(error, float)
    n = np.arange(1, e.size + 1, dtype=float)
    with np.errstate(invalid="ignore"):
        use = np.isfinite(e) & (e > window[0]) & (e < window[1])
        if not use.any():
            pos = np.isfinite(e) & (e > 0)
            if not pos.any():
                return math.nan, use
            use = np.zeros_like(pos)
            use[np.flatnonzero(pos)[np.argmin(e[pos])]] = True
    logc = np.mean(np.log(e[use]) - 2.0 * n[use] * math.log(lam))
    return float(math.exp(logc)), use


def _tick_name(t: float) -> str:
    return fmt_tick(t).replace(" tick", " controller tick")


def plot_tick_sweep(ds):
    """Error per cycle of the exact gait's open-loop replay for each controller tick.

    The figure answers "was it the controller's 1 ms time grid?": a tick rounds the swap time
    and so starts the run off the gait; the leading Floquet multiplier then amplifies the
    deviation ``delta`` by ``|lambda_max|`` per cycle, the error (~``|delta|^2``) by
    ``|lambda_max|^2``. The dashed line is that prediction anchored on the exact-timing run
    (fitted over its linear regime); parallel lines for every tick mean the same instability
    drives them all, and a finer tick only starts it smaller. The title states the verdict
    from the data (whether exact timing also leaves the gait).

    gids: ``error_<i>`` (tick i; ydata = ``error[i]``, x = cycles), ``prediction`` (x cycles,
    y ``c * lambda^(2n)``), ``error_bound``, ``to_bound_<i>`` (the first cycle above the
    bound), ``stop_<i>`` (where a run stopped early).
    """
    ticks = np.asarray(ds["tick"].values, float)
    cyc = np.asarray(ds["cycle"].values, float) if "cycle" in ds.coords \
        else np.arange(1, ds.sizes["cycle"] + 1, dtype=float)
    err = values_of(ds, "error")
    bound = attr_float(ds, "error_bound", 1e-2)
    lam = attr_float(ds, "leading_multiplier")
    to_bound = values_of(ds, "cycles_to_bound").astype(int)
    done = values_of(ds, "cycles_completed").astype(int) if "cycles_completed" in ds \
        else np.sum(np.isfinite(err), axis=1)
    status = values_of(ds, "status").astype(int) if "status" in ds else np.zeros(len(ticks), int)
    growth = values_of(ds, "growth_per_cycle") if "growth_per_cycle" in ds \
        else np.full(len(ticks), np.nan)
    order = np.argsort(-ticks)          # coarsest tick first, exact timing last
    palette = [VERMILLION, ORANGE, PURPLE, GREEN, SKY, BLACK]
    colour = {}
    for k, i in enumerate(order):
        colour[i] = BLUE if ticks[i] == 0 else palette[k % len(palette)]
    exact = [i for i in range(len(ticks)) if ticks[i] == 0]
    n_cycles = int(ds.sizes["cycle"])
    own = ds.attrs.get("replay") == "gait"          # a sequence gait's own controller
    at = "section" if "section_theta1" in ds.attrs else "vertical"

    def exceeded(i):
        e = err[i]
        return bool(np.any(e[np.isfinite(e)] > bound))

    coarse = float(ticks.max()) if ticks.size else 0.0
    coarse_name = fmt_tick(coarse).replace(" tick", "") if coarse > 0 else "controller"
    question = f"Was it the {coarse_name} time grid?"
    if exact and coarse == 0:                          # exact timing only: no question
        i0 = exact[0]
        title = ("Error per cycle of the exact-timing replay: " + (
            f"above {bound:g} from cycle {to_bound[i0]}" if exceeded(i0)
            else f"below {bound:g} for all {count(done[i0], 'cycle')}"))
        verdict = ("the gait leaves the bound without any tick" if exceeded(i0)
                   else f"no departure within {count(done[i0], 'cycle')}")
    elif exact and exceeded(exact[0]):
        i0 = exact[0]
        title = (f"{question}\nNo: with exact timing the run still leaves the gait "
                 f"(error > {bound:g} from cycle {to_bound[i0]})")
        verdict = (f"the {'' if own else 'open-loop '}gait itself is unstable; a tick only "
                   "sets the starting error, the multiplier does the rest")
    elif exact:
        i0 = exact[0]
        failed = [i for i in range(len(ticks)) if ticks[i] > 0 and exceeded(i)]
        title = (f"{question}\n" + ("Yes: with exact timing the gait holds all "
                                     f"{count(done[i0], 'cycle')}" if failed else
                                     "No run left the gait: error per cycle for each tick"))
        verdict = ("with exact timing the error stays below the bound" + (
            "; the tick's rounding is what drives the runs off the gait" if failed else ""))
    else:
        i0 = None
        title = ("Error per cycle of the gait's own controller for each controller tick"
                 if own else "Error per cycle of the exact gait's open-loop replay for each "
                 "controller tick")
        verdict = "no exact-timing run in this sweep"
    with style():
        fig = new_figure(figsize=(9.0, 6.8))
        src = ds.attrs.get("leading_multiplier_source")
        lam_txt = (f"Leading multiplier |λmax| = {lam:.4g} ⇒ the error grows × |λmax|² = "
                   f"{lam ** 2:.3g} per cycle (dashed line)"
                   if math.isfinite(lam) else "Leading multiplier unknown")
        if own and math.isfinite(lam) and abs(lam - 1.0) < 1e-6:
            lam_txt += (";\n|λmax| = 1 is the neutral multiplier (the free energy level): a "
                        "deviation along the gait family neither grows nor decays")
        gait = _gait_of(ds)
        how = ("run by its own controller (guards acted on at the ticks)" if own
               else "replayed open loop")
        sub = (f"Error per cycle of the exact gait {how}, one run per controller "
               f"tick.\n{lam_txt}.\nVerdict: {verdict}.\n"
               + (("Running" if own else "Replaying") + f" the {gait}"
                  + (f", {_times_of(ds)}" if _times_of(ds) else "") + "\n" if gait else "")
               + run_line(ds, tick=False, torque=attr_float(ds, "motor_torque", None)
                          if "motor_torque" in ds.attrs else None))
        body = two_titles(fig, title, sub)
        ax = body.subplots()
        handles = []
        for i in order:
            c = colour[i]
            e = err[i]
            ax.plot(cyc, _positive(e), marker="o", ms=3, lw=1.3, color=c, gid=f"error_{i}")
            if exceeded(i):
                ax.plot([cyc[to_bound[i] - 1]], [bound], marker="v", ms=9, color=c, mec="black",
                        mew=0.7, ls="none", zorder=6, gid=f"to_bound_{i}")
                when = f"error > {bound:g} from cycle {to_bound[i]}"
            else:
                when = f"error ≤ {bound:g} for all {count(done[i], 'cycle')}"
            stop = ""
            if status[i] not in (L.ST_OK, L.ST_END_TIME) and done[i] < n_cycles:
                ok = np.flatnonzero(np.isfinite(e) & (e > 0))
                if ok.size:
                    ax.plot([cyc[ok[-1]]], [e[ok[-1]]], marker="X", ms=10, mfc=c, mec="black",
                            mew=0.8, ls="none", zorder=6, gid=f"stop_{i}")
                stop = f"; {status_name(status[i]).replace('_', ' ')} after cycle {done[i]} (×)"
            g = (f"; fitted growth of √e: {growth[i]:.4g} per cycle" if np.isfinite(growth[i])
                 else "")
            handles.append(Line2D([], [], color=c, marker="o", ms=3,
                                  label=f"{_tick_name(ticks[i])}: {when}{stop}{g}"))
        if i0 is not None and math.isfinite(lam) and lam > 0:
            c0, used = prediction_anchor(err[i0], lam)
            if math.isfinite(c0):
                pred = c0 * lam ** (2.0 * cyc)
                ax.plot(cyc, pred, ls="--", lw=1.6, color="0.15", zorder=3, gid="prediction")
                handles.append(Line2D([], [], ls="--", color="0.15", label=(
                    r"prediction $c\,|\lambda_\mathrm{max}|^{2n}$, "
                    f"|λmax| = {lam:.4g}, anchored on the exact-timing run ("
                    + (f"cycles {int(cyc[used][0])}–{int(cyc[used][-1])})" if used.sum() > 1
                       else f"cycle {int(cyc[used][0])})")
                    + (f"\n(|λmax| from {src})" if src else ""))))
        ax.axhline(bound, color="0.35", ls=":", lw=1.2, gid="error_bound")
        handles.append(Line2D([], [], color="0.35", ls=":", label=(
            f"error bound {bound:g}; ▼ where each run first exceeds it")))
        ax.set_yscale("log")
        pos = err[np.isfinite(err) & (err > 0)]
        if pos.size:
            ax.set_ylim(pos.min() / 10, max(pos.max(), bound) * 10)
        ax.set_xlim(0, n_cycles + 1)
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_xlabel("gait cycle n")
        ax.set_ylabel(f"error e at the {at} crossing  {ERROR_UNITS}")
        body.legend(handles=handles, loc="outside lower center", ncols=1, frameon=False)
    return fig


# ----------------------------------------------------------------------------------------------
# basin
# ----------------------------------------------------------------------------------------------
def _edges(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, float)
    if v.size == 1:
        h = max(abs(v[0]) * 0.05, 1e-6)
        return np.array([v[0] - h, v[0] + h])
    mid = (v[1:] + v[:-1]) / 2
    return np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])


def plot_basin(ds, *, cmap: str = "viridis", numbers: int = 225):
    """Cycles an open-loop replay survives from starts offset from the gait.

    Cell ``(a, b)``: the start ``(dtheta1 + a, dtheta2 + b)``; its colour is the number of
    cycles before the error against the unperturbed gait exceeded ``error_bound`` (or the run
    fell); ``max_cycles`` means it never did. Integer colour steps; cells are numbered when
    there are at most ``numbers`` of them. A ring marks the gait itself (zero offset).

    gids: ``cycles`` (the QuadMesh; its array is ``cycles`` transposed, ``[i_d2, i_d1]``),
    ``gait`` (the ring at zero offset), ``count_<i>_<j>`` (the numbers).
    """
    o1, o2 = values_of(ds, "d_dtheta1"), values_of(ds, "d_dtheta2")
    cyc = np.asarray(ds["cycles"].transpose("d_dtheta1", "d_dtheta2").values)
    top = int(attr_float(ds, "max_cycles", float(cyc.max())))
    bound = attr_float(ds, "error_bound")
    tick = attr_float(ds, "tick")
    with style():
        fig = new_figure(figsize=(7.6, 6.8))
        gait = _gait_of(ds) or "the gait"
        what = (f"failure: error against the gait > {bound:g}" if math.isfinite(bound)
                else "failure: the run left the gait")
        starts = "start" if o1.size * o2.size == 1 else "starts"
        sub = (f"{o1.size}×{o2.size} {starts} around the {gait}; {what}, or the run fell; "
               f"{top} = never failed in {count(top, 'cycle')}\n"
               + (f"{_times_of(ds)}, " if _times_of(ds) else "")
               + (f"{fmt_tick(tick)}, " if math.isfinite(tick) else "")
               + run_line(ds, tick=False, torque=attr_float(ds, "motor_torque", None)
                          if "motor_torque" in ds.attrs else None))
        own = ds.attrs.get("replay") == "gait"
        body = two_titles(fig, "Basin of the gait under its own controller: cycles survived from "
                            "perturbed starts" if own else "Basin of the open-loop gait: "
                            "cycles survived from perturbed starts", sub)
        ax = body.subplots()
        ax.grid(False)
        base = matplotlib.colormaps[cmap]
        lo = int(min(cyc.min(), 0))
        bounds = np.arange(lo - 0.5, top + 1.5, 1.0)
        norm = BoundaryNorm(bounds, base.N)
        mesh = ax.pcolormesh(_edges(o1), _edges(o2), cyc.T, cmap=base, norm=norm,
                             shading="flat", gid="cycles")
        cb = body.colorbar(mesh, ax=ax, pad=0.02)
        cb.set_label(f"cycles before error > {bound:g}" if math.isfinite(bound)
                     else "cycles before failure")
        cb.locator = MaxNLocator(integer=True, steps=[1, 2, 5, 10])
        cb.update_ticks()
        numbered = cyc.size <= numbers
        if numbered:
            for i, a in enumerate(o1):
                for j, b in enumerate(o2):
                    v = int(cyc[i, j])
                    r, g, bb, _ = base(norm(v))
                    light = 0.299 * r + 0.587 * g + 0.114 * bb > 0.55
                    ax.text(a, b, str(v), ha="center", va="center", fontsize=9,
                            color="black" if light else "white", gid=f"count_{i}_{j}")
        ax.plot(0.0, 0.0, marker="o", ms=30 if numbered else 12, mfc="none", mec="white",
                mew=2.0, ls="none", zorder=5, gid="gait",
                path_effects=[withStroke(linewidth=4, foreground="black")])
        ax.set_xlabel(f"offset of the initial {D1} from the gait  {RATE}")
        ax.set_ylabel(f"offset of the initial {D2} from the gait  {RATE}")
        body.legend(handles=[Line2D([], [], marker="o", ms=14, mfc="none", mec="black", mew=2,
                                   ls="none", label=f"zero offset: the {gait}")],
                   loc="outside lower center", frameon=False)
    return fig


# ----------------------------------------------------------------------------------------------
# continuation
# ----------------------------------------------------------------------------------------------
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
    lam = _complex(ds, "multipliers")
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
        span = (f"{mu.size} points, {sym} = {mu[0]:.6g} → {mu[-1]:.6g}"
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
            sub += (f"{pin}, from floquet step {ds.attrs.get('floquet_step', '?')}\n"
                    f"stopped: {why}\n" + run_line(ds, tick=False))
            title = f"Sequence-gait family continued in {what}"
        else:
            gait = _gait_of(ds)
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
        body.legend(*axl.get_legend_handles_labels(), loc="outside lower center", ncols=2,
                   frameon=False)
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


# ----------------------------------------------------------------------------------------------
# work precision
# ----------------------------------------------------------------------------------------------
SCIPY_MARKERS = ("s", "^", "D", "v", "P")


def _times(x: float) -> str:
    """A ratio for text: 2 significant digits, no exponent (``250``, ``67``, ``1.3``)."""
    if not math.isfinite(x):
        return "?"
    return f"{x:.0f}" if x >= 10 else f"{x:.2g}"


def _kernel_style(method, i, colors):
    """Colour by Runge-Kutta pair; the PI-controlled variant (``"<pair>+pi"``) keeps its
    pair's colour, dotted with square markers (scipy's solve_ivp lines are dashed)."""
    pair, _, controller = method.partition("+")
    known = {"rk45": BLUE, "dop853": GREEN, "vern9": PURPLE}
    color = known.get(pair, colors[i % len(colors)])
    return (color, ":", "s") if controller else (color, "-", "o")


def plot_work_precision(ds):
    """Wall time per gait against error, log-log: one line per kernel integrator over the
    tolerance ladder (points labelled with their rtol), scipy's ``solve_ivp`` methods dashed
    with their own markers. Left: error of the gait error value; right: of the event times.
    Lower left is better. The title names the reference the errors are measured against.

    gids: ``kernel_<method>_<value|times>`` (x error, y ``time_per_gait``),
    ``scipy_<method>_<value|times>``, ``rtol_<method>_<j>`` (the labels, left panel),
    ``mismatch_<method>`` (points whose status differs from the reference).
    """
    methods = [str(m) for m in np.atleast_1d(ds["method"].values)]
    rtols = values_of(ds, "rtol")
    t = values_of(ds, "time_per_gait")
    has_scipy = "scipy_time_per_gait" in ds and ds.sizes.get("scipy_method", 0) > 0
    ref = ds.attrs.get("reference", "?")
    npts = ds.attrs.get("n_points")
    kcol = [BLUE, GREEN, PURPLE, BLACK]
    scol = [VERMILLION, ORANGE, SKY, PURPLE]
    with style():
        fig = new_figure(figsize=(10.0, 6.4))
        rep = ds.attrs.get("repeat")
        sub = (f"Errors: max over {npts if npts is not None else '?'} gaits of |result − "
               f"reference|, reference {ref}; time: wall time per gait"
               + (f", best of {rep}" if rep is not None else "")
               + " (machine-dependent)\n" + run_line(ds, tick=False, integrator=False))
        body = two_titles(fig, f"Work-precision: wall time per gait against error "
                            f"(reference: {ref})", sub)
        axv, axt = body.subplots(1, 2, sharey=True)
        handles = []
        # rtol labels above the slowest kernel line, below the others
        with np.errstate(invalid="ignore", divide="ignore"):
            mean_t = [np.nanmean(np.log(row)) if np.isfinite(row).any() else -np.inf
                      for row in t]
        above = int(np.argmax(mean_t)) if len(mean_t) else -1
        for which, ax, xlabel in (("value", axv, f"max error of the gait error value e  {ERROR_UNITS}"),
                                  ("times", axt, "max error of the event times  [s]")):
            e = values_of(ds, f"error_{which}")
            for i, m in enumerate(methods):
                c, ls, mk = _kernel_style(m, i, kcol)
                ax.plot(_positive(e[i]), t[i], marker=mk, ms=5, color=c, lw=1.6, ls=ls,
                        gid=f"kernel_{m}_{which}")
                # the PI variants' points are not labelled: they would sit on their pair's
                labelled = "+" not in m
                for j, r in enumerate(rtols if labelled else ()):
                    if np.isfinite(e[i, j]) and e[i, j] > 0 and np.isfinite(t[i, j]):
                        ax.annotate(sci(r, 1), (e[i, j], t[i, j]),
                                    xytext=(0, 7 if i == above else -15), ha="center",
                                    textcoords="offset points", fontsize=7.5, color=c,
                                    path_effects=OUTLINE,
                                    gid=f"rtol_{m}_{j}" if which == "value" else None)
                if "status_mismatch" in ds:
                    mm = values_of(ds, "status_mismatch")[i] > 0
                    if mm.any():
                        ax.plot(_positive(e[i][mm]), t[i][mm], marker="o", ms=12, mfc="none",
                                mec=VERMILLION, mew=1.5, ls="none", gid=f"mismatch_{m}")
                if which == "value":
                    handles.append(Line2D([], [], color=c, marker=mk, ms=5, ls=ls,
                                          label=f"kernel {m} (rtol "
                                                f"{sci(rtols.min(), 1)}…{sci(rtols.max(), 1)}"
                                                + (", labelled)" if labelled else ")")))
            if has_scipy:
                smeth = [str(m) for m in np.atleast_1d(ds["scipy_method"].values)]
                srt = values_of(ds, "scipy_rtol")
                st = values_of(ds, "scipy_time_per_gait")
                se = values_of(ds, f"scipy_error_{which}")
                kt = values_of(ds, "kernel_time_same_points") if "kernel_time_same_points" \
                    in ds else None
                for i, m in enumerate(smeth):
                    c = scol[i % len(scol)]
                    ax.plot(_positive(se[i]), st[i], marker=SCIPY_MARKERS[i % 5], ms=6,
                            color=c, ls="--", lw=1.2, gid=f"scipy_{m}_{which}")
                    if which == "value":
                        ratio = ""
                        if kt is not None and np.isfinite(kt).any():
                            r = st[i] / kt
                            lo_r, hi_r = _times(np.nanmin(r)), _times(np.nanmax(r))
                            ratio = (f"; {lo_r}{'' if lo_r == hi_r else '–' + hi_r}× the "
                                     "time of the kernel's dop853 on the same gaits")
                        handles.append(Line2D([], [], color=c, marker=SCIPY_MARKERS[i % 5],
                                              ls="--", label=f"scipy solve_ivp {m} (rtol "
                                              f"{', '.join(sci(x, 1) for x in srt)}){ratio}"))
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.margins(x=0.06, y=0.1)            # room for the rtol labels
            ax.set_xlabel(xlabel)
        axv.set_ylabel("wall time per gait  [s]")
        axv.set_title("gait error value", loc="left", **SUB)
        axt.set_title("event times (swap, motor off, vertical crossing)", loc="left", **SUB)
        if "status_mismatch" in ds and (values_of(ds, "status_mismatch") > 0).any():
            handles.append(Line2D([], [], marker="o", ms=10, mfc="none", mec=VERMILLION,
                                  ls="none", label="status differs from the reference at "
                                                   "some gaits"))
        body.legend(handles=handles, loc="outside lower center", ncols=1, frameon=False)
    return fig


# ----------------------------------------------------------------------------------------------
#: how the analysis steps' figures are drawn (one per dataset)
DRAWINGS = {
    ("shoot", "newton"): Drawing(lambda d: plot_shoot_convergence(d[0])),
    ("floquet", "multipliers"): Drawing(lambda d: plot_floquet_multipliers(d[0])),
    ("tick_sweep", "error_growth"): Drawing(lambda d: plot_tick_sweep(d[0])),
    ("basin", "cycles_map"): Drawing(lambda d: plot_basin(d[0])),
    ("continuation", "branch"): Drawing(lambda d: plot_continuation(d[0])),
    ("work_precision", "work_precision"): Drawing(lambda d: plot_work_precision(d[0])),
}
