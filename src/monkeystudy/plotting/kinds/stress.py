"""Figure of the ``stress`` dataset (docs/datasets.md, ``stress``).

:func:`plot_stress` draws, in one figure:

* the relative energy drift of the unforced, frictionless runs against time (log-log), one
  line per (phase, tolerance), with a dashed linear-growth reference and the round-off band
  below which the growth exponent is not fitted; the title states the growth exponents;
* the long runs' outcomes: cycles completed per run, coloured by the status it stopped with;
* the extreme cases: how many runs of each case ended with each status, and whether every
  result marked ok was finite.

:data:`DRAWINGS` registers it under ``("stress", "stress")`` (file ``<step>_stress``);
:func:`monkeystudy.plotting.report.plan` draws it for every such dataset of a study.
"""
from __future__ import annotations

import math

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from ..drawing import Drawing
from ..common import (
    BLACK, BLUE, GREEN, ORANGE, PURPLE, SKY, VERMILLION, YELLOW, count, fmt_tick, json_attr,
    new_figure, style,
)
from ..labels import OUTLINE, SUB, attr_float, sci, two_titles, values_of, run_line
from ...simulation import STATUS_NAMES

#: colour of each status in the outcome panels
STATUS_COLOUR = {
    "ok": GREEN, "fell": VERMILLION, "end_time": BLUE, "energy_not_restored": ORANGE,
    "no_switch": PURPLE, "unreachable": "0.62", "no_return_to_vertical": SKY,
    "non_finite": "#7a0019", "step_failure": BLACK, "buffer_full": "0.35", "horizon": YELLOW,
}
#: one colour per tolerance (tightest last), one line style and marker per phase
RTOL_COLOURS = (VERMILLION, ORANGE, BLUE, GREEN, PURPLE, SKY, BLACK)
PHASE_STYLE = {"swing": ("-", "o"), "flight": (":", "s")}
#: how a long run is named in the figure
RUN_TITLES = {"open_loop_tick": "open loop, ticked", "open_loop_exact": "open loop, exact",
              "search_exact": "state-based, exact", "search_tick": "state-based, ticked"}
#: how an extreme case is named in the figure
CASE_TITLES = {"mass_ratio_1_100": "masses 1 : 100", "mass_ratio_100_1": "masses 100 : 1",
               "tiny_inertia": "inertias 1e-8 kg m²", "cg_at_the_ends": "CGs at the link ends",
               "huge_velocities": "rates ±1e3 rad s⁻¹", "coulomb_sticking": "Coulomb sticking"}

EPS = float(np.finfo(float).eps)


def _labels(ds, name: str) -> list[str]:
    return [str(x) for x in np.atleast_1d(ds[name].values)]


def _status(code: int) -> str:
    code = int(code)
    return STATUS_NAMES[code] if 0 <= code < len(STATUS_NAMES) else f"status {code}"


def _exp(x: float) -> str:
    return f"{x:.2f}".replace("-", "−") if math.isfinite(x) else "–"


def _verdict(e: np.ndarray) -> str:
    """What a phase's growth exponents say: linear growth, a random walk, no growth."""
    e = e[np.isfinite(e)]
    if not e.size:
        return "at round-off"
    if np.all(np.abs(e - 1.0) <= 0.2):
        return "linear growth"
    if np.all(e <= 0.3):
        return "no growth"
    if np.all(np.abs(e - 0.5) <= 0.2):
        return "random-walk growth"
    return "mixed"


def _run_title(ds, k: int, name: str) -> str:
    base = RUN_TITLES.get(name, name.replace("_", " "))
    if "tick" in ds:
        t = float(ds["tick"].values[k])
        if t > 0:
            base = base.replace("ticked", fmt_tick(t))
    return base


def plot_stress(ds):
    """Energy drift against time, long-run outcomes and extreme-case statuses of a stress
    dataset.

    gids: ``drift_<phase>_<j>`` (one line per phase and tolerance ``drift_rtol[j]``; x
    ``time``, y ``energy_drift``), ``linear_reference`` (the dashed slope-1 line),
    ``round_off`` (the band below ``drift_floor``), ``run_<k>`` (bar of run ``k``, width
    ``cycles_completed``), ``run_label_<k>``, ``requested_cycles``,
    ``case_<i>_<status>`` (bar segment of case ``i``: x from the counts of the statuses
    before it, width ``status_counts``), ``finite_<i>`` (the finite / non-finite label).
    """
    phases = _labels(ds, "drift_phase")
    rtols = values_of(ds, "drift_rtol")
    t = values_of(ds, "time")
    drift = values_of(ds, "energy_drift")
    expo = values_of(ds, "growth_exponent")
    per = values_of(ds, "drift_per_period")
    floor = attr_float(ds, "drift_floor", 100 * EPS)
    runs = _labels(ds, "run")
    cycles = values_of(ds, "cycles_completed").astype(int)
    rstat = values_of(ds, "run_status").astype(int)
    height = values_of(ds, "final_pivot_height")
    want = int(attr_float(ds, "cycles", float(cycles.max()) if cycles.size else 0.0))
    cases = _labels(ds, "case")
    counts = np.asarray(ds["status_counts"].transpose("case", "status").values, int)
    codes = np.asarray(ds["status"].values, int)
    finite_ok = values_of(ds, "finite_ok").astype(int)
    periods = attr_float(ds, "periods")
    order = np.argsort(-rtols)                     # loosest tolerance first

    def exps(ph: int) -> str:
        return " / ".join(_exp(expo[ph, j]) for j in order)

    tol_txt = " / ".join(sci(rtols[j], 1) for j in order)
    title = (f"Numerical stress tests. Energy drift growth exponents at rtol {tol_txt}:\n"
             + ", ".join(f"{p} {exps(i)} ({_verdict(expo[i])})"
                         for i, p in enumerate(phases)))
    with style():
        fig = new_figure(figsize=(12.0, 7.6))
        sub = ("Left: unforced, frictionless runs; relative drift |E − E0| / (|K| + |V|) "
               "at log-spaced checkpoints; growth exponent = log-log slope over the last "
               f"decade, fitted above {sci(floor, 1)} (round-off). Right: long runs of "
               f"{count(want, 'cycle')} and extreme cases, coloured by the status they ended "
               "with.\n"
               + run_line(ds, tick=False))
        body = two_titles(fig, title, sub)
        gs = body.add_gridspec(2, 2, width_ratios=[1.45, 1.0], height_ratios=[1.0, 1.25])
        axd = body.add_subplot(gs[:, 0])
        axr = body.add_subplot(gs[0, 1])
        axe = body.add_subplot(gs[1, 1])

        # --- energy drift ------------------------------------------------------------------
        handles = []
        for i, ph in enumerate(phases):
            ls, mk = PHASE_STYLE.get(ph, ("--", "^"))
            for k, j in enumerate(order):
                c = RTOL_COLOURS[k % len(RTOL_COLOURS)]
                d = np.ma.masked_where(~np.isfinite(drift[i, j]) | (drift[i, j] <= 0),
                                       drift[i, j])
                axd.plot(t[i], d, ls=ls, marker=mk, ms=4, lw=1.5, color=c,
                         mfc=c if ph == "swing" else "white", gid=f"drift_{ph}_{j}")
                handles.append(Line2D([], [], ls=ls, marker=mk, ms=4, color=c,
                                      mfc=c if ph == "swing" else "white",
                                      label=f"{ph}, rtol {sci(rtols[j], 1)}: exponent "
                                            f"{_exp(expo[i, j])}"
                                            + (" (round-off)" if not np.isfinite(expo[i, j])
                                               else "")
                                            + f", {sci(per[i, j])} per period"))
        pos = drift[np.isfinite(drift) & (drift > 0)]
        tpos = t[np.isfinite(t) & (t > 0)]
        if pos.size and tpos.size:
            # anchor the slope-1 line on the end of the line with the largest final drift
            last = np.where(np.isfinite(drift[..., -1]), drift[..., -1], -np.inf)
            i0, j0 = np.unravel_index(int(np.argmax(last)), last.shape)
            ta = np.array([tpos.min(), tpos.max()])
            ref = drift[i0, j0, -1] * ta / t[i0, -1]
            axd.plot(ta, ref, ls="--", color="0.15", lw=1.3, zorder=1, gid="linear_reference")
            handles.append(Line2D([], [], ls="--", color="0.15",
                                  label="linear growth (∝ t), through the largest final "
                                        "drift"))
            lo = min(pos.min(), floor) / 4
            axd.axhspan(lo, floor, color="0.88", zorder=0, lw=0, gid="round_off")
            handles.append(Patch(color="0.88", label=f"round-off: below {sci(floor, 1)} = "
                                                     "100 ε (not fitted)"))
            axd.set_ylim(lo, pos.max() * 30)
        axd.set_xscale("log")
        axd.set_yscale("log")
        axd.set_xlabel("time  [s]")
        axd.set_ylabel("relative energy drift |E − E0| / (|K| + |V|)  [1]")
        per_txt = ", ".join(f"{p} {float(v):.3g} s" for p, v in
                            zip(phases, values_of(ds, "period"))) if "period" in ds else ""
        axd.set_title("Energy drift of unforced, frictionless runs"
                      + (f" ({periods:g} reference periods: {per_txt})"
                         if math.isfinite(periods) else ""), **SUB)
        body.legend(handles=handles, loc="outside lower left", ncols=2, fontsize=8,
                    frameon=False)

        # --- long runs -----------------------------------------------------------------------
        y = np.arange(len(runs))[::-1]
        axr.grid(False, axis="y")
        top = max(want, int(cycles.max()) if cycles.size else 1, 1)
        for k, name in enumerate(runs):
            st = _status(rstat[k])
            bar = axr.barh(y[k], cycles[k], height=0.6, color=STATUS_COLOUR.get(st, "0.5"),
                           edgecolor="black", lw=0.6)
            bar.patches[0].set_gid(f"run_{k}")
            txt = (f"{st.replace('_', ' ')}: {cycles[k]} cycle{'s' if cycles[k] != 1 else ''}"
                   f", pivot at {height[k]:.3g} m").replace("-", "−")
            inside = cycles[k] > 0.55 * top
            axr.text(cycles[k] - 0.01 * top if inside else cycles[k] + 0.01 * top, y[k], txt,
                     ha="right" if inside else "left", va="center", fontsize=8,
                     color="white" if inside else "black",
                     path_effects=None if inside else OUTLINE, gid=f"run_label_{k}")
        axr.axvline(want, color="0.3", ls=":", lw=1.2, gid="requested_cycles")
        axr.set_yticks(y, [_run_title(ds, k, r) for k, r in enumerate(runs)])
        axr.set_xlim(0, top * 1.04)
        axr.xaxis.set_major_locator(MaxNLocator(integer=True, steps=[1, 2, 2.5, 5, 10]))
        axr.set_xlabel("cycles completed  [1]")
        start = json_attr(ds, "long_run_start")
        where = (f" from ({float(start[0]):g}, {float(start[1]):g}) rad s⁻¹"
                 if isinstance(start, list) and len(start) == 2 else "")
        axr.set_title(f"Long runs{where}\ndotted: {count(want, 'cycle')} requested; pivot: final "
                      "attached-end height", **SUB)

        # --- extreme cases -------------------------------------------------------------------
        ye = np.arange(len(cases))[::-1]
        axe.grid(False, axis="y")
        present = set()
        n_max = int(counts.sum(axis=1).max()) if counts.size else 1
        for i, case in enumerate(cases):
            left = 0
            for j, code in enumerate(codes):
                n = int(counts[i, j])
                if n == 0:
                    continue
                st = _status(code)
                present.add(st)
                bar = axe.barh(ye[i], n, left=left, height=0.6,
                               color=STATUS_COLOUR.get(st, "0.5"), edgecolor="black", lw=0.6)
                bar.patches[0].set_gid(f"case_{i}_{st}")
                axe.text(left + n / 2, ye[i], str(n), ha="center", va="center", fontsize=8,
                         color="white" if st in ("fell", "no_switch", "end_time",
                                                 "step_failure", "non_finite") else "black")
                left += n
            ok = bool(finite_ok[i])
            axe.text(left + 0.02 * n_max, ye[i], "finite ✓" if ok else "NON-FINITE ✗",
                     ha="left", va="center", fontsize=8, color=BLACK if ok else VERMILLION,
                     fontweight="normal" if ok else "bold", gid=f"finite_{i}")
        axe.set_yticks(ye, [CASE_TITLES.get(c, c.replace("_", " ")) for c in cases])
        axe.set_xlim(0, n_max * 1.3)
        axe.set_xlabel("runs of the case  [1]")
        axe.set_title("Extreme parameters: the status of each run;\n✓: every result marked ok "
                      "is finite", **SUB)
        used = {_status(s) for s in rstat} | present
        body.legend(handles=[Patch(facecolor=STATUS_COLOUR.get(s, "0.5"), edgecolor="black",
                                   lw=0.6, label=s.replace("_", " "))
                             for s in STATUS_NAMES if s in used],
                    loc="outside lower right", ncols=3, fontsize=8, frameon=False,
                    title="status the run ended with", title_fontsize=8.5)
    return fig


# ----------------------------------------------------------------------------------------------
#: how the stress step's figure is drawn
DRAWINGS = {
    ("stress", "stress"): Drawing(
        title="energy drift, long runs, extreme cases",
        caption="Left: relative energy drift against time per tolerance (a slope of 1 is linear "
                "growth, as for any non-symplectic method). Middle: how each long run ended. "
                "Right: the status counts of the extreme cases.",
        draw=lambda d: plot_stress(d[0])),
}
