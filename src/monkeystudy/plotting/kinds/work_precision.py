"""The work_precision step's figure: wall time per gait against error for each integrator
and tolerance, scipy beside the kernel.

Artists carry ``gid`` s (listed in the docstring) so the tests can read back their data.
"""
from __future__ import annotations

import math

import numpy as np
from matplotlib.lines import Line2D

from ..drawing import Drawing
from ..common import (
    BLACK, BLUE, ERROR_UNITS, GREEN, ORANGE, PURPLE, SKY, VERMILLION, count, new_figure,
    style,
)
from ..labels import OUTLINE, SUB, positive, run_line, sci, two_titles, values_of


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
        sub = (f"Errors: max over {count(npts, 'gait') if npts is not None else '? gaits'} of "
               "|result − "
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
                ax.plot(positive(e[i]), t[i], marker=mk, ms=5, color=c, lw=1.6, ls=ls,
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
                        ax.plot(positive(e[i][mm]), t[i][mm], marker="o", ms=12, mfc="none",
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
                    ax.plot(positive(se[i]), st[i], marker=SCIPY_MARKERS[i % 5], ms=6,
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


#: how the work_precision step's figure is drawn
DRAWINGS = {
    ("work_precision", "work_precision"): Drawing(
        title="wall time per gait against error",
        caption="Time per gait against the error of the gait error, one line per integrator: "
                "lower left is better; the ratio to scipy's solve_ivp on the same gaits is in the "
                "legend.",
        draw=lambda d: plot_work_precision(d[0])),
}
