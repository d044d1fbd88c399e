"""The shoot step's figure: the residual norm per Newton iteration, one line per solution,
and ``r[k+1]`` against ``r[k]`` with a slope-2 line (quadratic convergence).

Artists carry ``gid`` s (listed in the docstring) so the tests can read back their data.
"""
from __future__ import annotations

import math

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.ticker import FixedLocator, MaxNLocator

from ..drawing import Drawing
from ..common import (
    BLACK, BLUE, GREEN, ORANGE, PURPLE, SKY, VERMILLION, count, json_attr, new_figure,
    readable_log_axis, style,
)
from ..labels import OUTLINE, SUB, attr_float, positive, run_line, sci, two_titles, values_of


SHOOT_METHODS = ("Gauss-Newton", "grazing")


def quadratic_constant(history, floor: float) -> float:
    """``C`` of the quadratic model ``r[k+1] = C r[k]^2`` fitted to a Newton history: the
    median of ``r[k+1] / r[k]^2`` over the steps that end above ``floor`` (round-off) and
    start below 1 (the local regime); NaN when there is no such step."""
    h = np.asarray(history, float)
    h = h[np.isfinite(h)]
    a, b = h[:-1], h[1:]
    ok = (a > 0) & (a < 1) & (b > floor)
    return float(np.median(b[ok] / a[ok] ** 2)) if ok.any() else math.nan


def decade_ticks(lo: float, hi: float, most: int = 6) -> np.ndarray:
    """Powers of ten in ``[lo, hi]``, every k-th (the fewest k leaving at most ``most``),
    taken so that ``10^0`` is among them when in range."""
    k0, k1 = math.ceil(math.log10(lo)), math.floor(math.log10(hi))
    if k1 < k0:
        return np.array([])
    step = max(1, math.ceil((k1 - k0 + 1) / most))
    first = k0 + (-k0) % step           # aligned to 0: 10^0 is a tick when in range
    return 10.0 ** np.arange(first, k1 + 1, step, dtype=float)


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
            ax.plot(x, positive(y), marker="o", ms=3.5, color=c, gid=f"history_{i}")
            m = SHOOT_METHODS[meth[i]] if 0 <= meth[i] < len(SHOOT_METHODS) else "?"
            state = (f"converged in {count(y.size - 1, 'iteration')}" if conv[i] == 1
                     else f"not converged, stopped after {count(y.size - 1, 'iteration')}")
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
        readable_log_axis(ax)
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
        if r.size:
            # the same powers of ten on both axes (at most six), so that the square's slopes
            # read from its labels
            for axis in (axr.xaxis, axr.yaxis):
                axis.set_major_locator(FixedLocator(decade_ticks(lo, hi)))
        axr.set_box_aspect(1.0)                 # equal ranges in a square: slopes read true
        axr.set_xlabel("residual norm r[k]  [1]")
        axr.set_ylabel("next residual norm r[k+1]  [1]")
        axr.set_title("order of convergence", loc="left", **SUB)
        body.legend(handles=handles, loc="outside lower center", ncols=1, frameon=False)
    return fig


#: how the shoot step's figure is drawn
DRAWINGS = {
    ("shoot", "newton"): Drawing(
        title="residual norm per Newton iteration",
        caption="Each solution's residual norm per Newton iteration on a log scale: quadratic "
                "convergence shows as the exponent doubling; a line that stalls did not converge.",
        draw=lambda d: plot_shoot_convergence(d[0])),
}
