"""The basin step's figure: cycles to failure over start offsets around the gait.

Artists carry ``gid`` s (listed in the docstring) so the tests can read back their data.
"""
from __future__ import annotations

import math

import matplotlib
import numpy as np
from matplotlib.colors import BoundaryNorm
from matplotlib.lines import Line2D
from matplotlib.patheffects import withStroke
from matplotlib.ticker import MaxNLocator

from ..drawing import Drawing
from ..common import (
    count, fmt_tick,
    new_figure, style,
)
from ..labels import D1, D2, RATE, attr_float, gait_of, run_line, times_of, two_titles, values_of


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
        gait = gait_of(ds) or "the gait"
        what = (f"failure: error against the gait > {bound:g}" if math.isfinite(bound)
                else "failure: the run left the gait")
        starts = "start" if o1.size * o2.size == 1 else "starts"
        sub = (f"{o1.size}×{o2.size} {starts} around the {gait}; {what}, or the run fell; "
               f"{top} = never failed in {count(top, 'cycle')}\n"
               + (f"{times_of(ds)}, " if times_of(ds) else "")
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


#: how the basin step's figure is drawn
DRAWINGS = {
    ("basin", "cycles_map"): Drawing(
        title="cycles to failure around the gait",
        caption="Cycles survived from each perturbed start (colour), the gait at the centre: a "
                "stable gait has a patch of starts that last max_cycles; an unstable one only a "
                "thin band, or nothing.",
        draw=lambda d: plot_basin(d[0])),
}
