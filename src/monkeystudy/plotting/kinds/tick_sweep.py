"""The tick_sweep step's figure: error per cycle for each controller tick, with the growth
``|lambda_max|^(2n)`` the leading multiplier predicts (the "was it the 1 ms grid?" figure).

Artists carry ``gid`` s (listed in the docstring) so the tests can read back their data.
"""
from __future__ import annotations

import math

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from ..drawing import Drawing
from ..common import (
    BLACK, BLUE, ERROR_UNITS, GREEN, ORANGE, PURPLE, SKY, VERMILLION, all_of, count, fmt_tick,
    new_figure, status_name, style,
)
from ...simulation import Status
from ..labels import attr_float, gait_of, positive, run_line, times_of, two_titles, values_of


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
            else f"below {bound:g} for {all_of(done[i0], 'cycle')}"))
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
        title = (f"{question}\n" + ("Yes: with exact timing the gait holds "
                                     f"{all_of(done[i0], 'cycle')}" if failed else
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
        gait = gait_of(ds)
        how = ("run by its own controller (guards acted on at the ticks)" if own
               else "replayed open loop")
        sub = (f"Error per cycle of the exact gait {how}, one run per controller "
               f"tick.\n{lam_txt}.\nVerdict: {verdict}.\n"
               + (("Running" if own else "Replaying") + f" the {gait}"
                  + (f", {times_of(ds)}" if times_of(ds) else "") + "\n" if gait else "")
               + run_line(ds, tick=False, torque=attr_float(ds, "motor_torque", None)
                          if "motor_torque" in ds.attrs else None))
        body = two_titles(fig, title, sub)
        ax = body.subplots()
        handles = []
        for i in order:
            c = colour[i]
            e = err[i]
            ax.plot(cyc, positive(e), marker="o", ms=3, lw=1.3, color=c, gid=f"error_{i}")
            if exceeded(i):
                ax.plot([cyc[to_bound[i] - 1]], [bound], marker="v", ms=9, color=c, mec="black",
                        mew=0.7, ls="none", zorder=6, gid=f"to_bound_{i}")
                when = f"error > {bound:g} from cycle {to_bound[i]}"
            else:
                when = f"error ≤ {bound:g} for {all_of(done[i], 'cycle')}"
            stop = ""
            if status[i] not in (Status.OK, Status.END_TIME) and done[i] < n_cycles:
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


#: how the tick_sweep step's figure is drawn
DRAWINGS = {
    ("tick_sweep", "error_growth"): Drawing(
        title="error per cycle per tick, |lambda|^2n",
        caption="The error per cycle for each controller tick beside the growth the leading "
                "multiplier predicts (dashed): a finer tick only delays the fall when the lines "
                "run parallel to the prediction.",
        draw=lambda d: plot_tick_sweep(d[0])),
}
