"""Error maps of a grid dataset: the 3-D surface (study fig. 3) and the intensity map (figs. 4,
9 and 10).

Grid points without a gait (``status != 0``, the study's "not enough energy" region and other
failures) have no error value; they are drawn as their own categories, never as numbers:
hatched patches of distinct colours on the map, a flat floor of the same colours under the
surface.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.colors import LightSource, Normalize
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, PathPatch
from matplotlib.patheffects import withStroke
from matplotlib.path import Path as MplPath
from matplotlib.ticker import MaxNLocator, NullFormatter
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from scipy import ndimage

from ..simulation import Status
from .common import (
    ERROR_UNITS, MINIMUM_COLOUR, count, finite, new_figure, readable_log_axis, run_label,
    status_name, style,
)
from .labels import duration
from .drawing import NothingToDraw

D1_LABEL = r"initial $\dot\theta_1$  [rad s$^{-1}$]"
D2_LABEL = r"initial $\dot\theta_2$  [rad s$^{-1}$]"

#: No-gait categories: (key, status codes or None for "every other failure", colour, hatch,
#: legend text). The first two are the study's flat "not enough energy" region.
NO_GAIT = (
    ("unreachable", (Status.UNREACHABLE,), "#7f98bd", "///",
     "no gait: B cannot reach A's height (energy bound, not integrated)"),
    ("no_switch", (Status.NO_SWITCH,), "#b3d1ee", "\\\\\\",
     "no gait: B never reached A's height"),
    ("other", None, "#33b5a5", "xx", "no gait: {names}"),
)
#: the same categories' legend text for a sequence gait (its own guards and section)
SEQUENCE_LABELS = {"no_switch": "no cycle: the free end never reached its catch height",
                   "other": "no cycle: {names}"}
MISSING = -1   # a cell of the plotting grid without a dataset point


@dataclass
class GridData:
    """A grid dataset as 2-D numpy arrays indexed ``[i_dtheta1, i_dtheta2]``."""

    dtheta1: np.ndarray
    dtheta2: np.ndarray
    error: np.ndarray    # NaN where there is no gait
    status: np.ndarray   # int, MISSING where the dataset has no point
    sequence: bool = False  # a sequence gait's cycle (section error), not the horizontal gait
    listed: int = 0         # the points of an explicit point list (0: the product of two axes)

    @property
    def ok(self) -> np.ndarray:
        return (self.status == Status.OK) & np.isfinite(self.error)

    def category_masks(self) -> list[tuple[str, np.ndarray, str, str, str]]:
        """``(key, mask, colour, hatch, label)`` for each no-gait category present."""
        failed = (self.status != Status.OK) & (self.status != MISSING)
        out, claimed = [], np.zeros_like(failed)
        for key, codes, colour, hatch, label in NO_GAIT:
            if self.sequence:
                label = SEQUENCE_LABELS.get(key, label)
            if codes is None:
                mask = failed & ~claimed
                names = sorted({status_name(c) for c in np.unique(self.status[mask])})
                label = label.format(names=", ".join(n.replace("_", " ") for n in names))
            else:
                mask = np.isin(self.status, codes)
            claimed |= mask
            if mask.any():
                out.append((key, mask, colour, hatch,
                            f"{label} ({count(mask.sum(), 'point')})"))
        return out


def grid_arrays(ds) -> GridData:
    """Read a ``grid`` dataset (2-D dims, or explicit points on dim ``point``)."""
    if "point" in ds.dims:
        p1 = np.asarray(ds["dtheta1"].values, float)
        p2 = np.asarray(ds["dtheta2"].values, float)
        d1, i1 = np.unique(p1, return_inverse=True)
        d2, i2 = np.unique(p2, return_inverse=True)
        err = np.full((d1.size, d2.size), np.nan)
        st = np.full((d1.size, d2.size), MISSING, dtype=int)
        err[i1, i2] = np.asarray(ds["error"].values, float)
        st[i1, i2] = np.asarray(ds["status"].values, int)
    else:
        d1 = np.asarray(ds["dtheta1"].values, float)
        d2 = np.asarray(ds["dtheta2"].values, float)
        err = np.asarray(ds["error"].transpose("dtheta1", "dtheta2").values, float)
        st = np.asarray(ds["status"].transpose("dtheta1", "dtheta2").values, int)
    err = np.where(st == Status.OK, err, np.nan)    # a no-gait point never shows a number
    listed = int(ds.sizes["point"]) if "point" in ds.dims else 0
    return GridData(d1, d2, err, st, is_sequence(ds), listed)


def is_sequence(ds) -> bool:
    """Whether a grid or refine dataset names its gait's cycle per segment (``t_segment``):
    a sequence gait's, whose error is the section error."""
    return "t_segment" in ds.variables


def cell_edges(v: np.ndarray) -> np.ndarray:
    """Edges of cells centred on the (sorted) values ``v``."""
    v = np.asarray(v, float)
    if v.size == 1:
        return np.array([v[0] - 0.5, v[0] + 0.5])
    mid = 0.5 * (v[1:] + v[:-1])
    return np.concatenate([[v[0] - (mid[0] - v[0])], mid, [v[-1] + (v[-1] - mid[-1])]])


def cell_runs(mask: np.ndarray, e1: np.ndarray, e2: np.ndarray):
    """``(x0, x1, y0, y1)`` of each run of consecutive cells along dtheta2 where
    ``mask[i1, i2]`` (cell edges ``e1``, ``e2``), column by column."""
    for i in range(mask.shape[0]):
        col = np.concatenate([[False], mask[i], [False]])
        starts = np.flatnonzero(~col[:-1] & col[1:])
        stops = np.flatnonzero(col[:-1] & ~col[1:])
        for a, b in zip(starts, stops):
            yield e1[i], e1[i + 1], e2[a], e2[b]


def mask_path(mask: np.ndarray, e1: np.ndarray, e2: np.ndarray) -> MplPath:
    """One compound path of the cells where ``mask[i1, i2]`` (x = dtheta1, y = dtheta2),
    consecutive cells along dtheta2 merged into one rectangle."""
    verts, codes = [], []
    for x0, x1, y0, y1 in cell_runs(mask, e1, e2):
        verts += [(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]
        codes += [MplPath.MOVETO, MplPath.LINETO, MplPath.LINETO, MplPath.LINETO,
                  MplPath.CLOSEPOLY]
    return MplPath(np.array(verts, float).reshape(-1, 2), codes)


def _hatch_patch(path, colour, hatch, gid):
    kw = dict(facecolor=colour, edgecolor="#42526e", hatch=hatch, linewidth=0.0, gid=gid,
              zorder=2)
    try:
        return PathPatch(path, hatchcolor="#42526e", **kw)
    except (AttributeError, TypeError):   # matplotlib < 3.10: hatches take the edge colour
        return PathPatch(path, **kw)


def _legend_patch(colour, hatch, label):
    kw = dict(facecolor=colour, edgecolor="#42526e", hatch=hatch, linewidth=0.5, label=label)
    try:
        return Patch(hatchcolor="#42526e", **kw)
    except (AttributeError, TypeError):
        return Patch(**kw)


@dataclass
class Minimum:
    """A located minimum (from a ``refine`` dataset) to mark on a map."""

    label: str
    dtheta1: float
    dtheta2: float
    error: float
    ok: bool
    path1: np.ndarray
    path2: np.ndarray
    start: tuple[float, float] | None


def _split_starts(refine) -> list[tuple[str, object]]:
    """``(label, dataset)`` per start of a refine dataset (a multi-start dataset has a leading
    dim ``start``: one minimum each)."""
    step = str(refine.attrs.get("step_name", "minimum"))
    if "start" in refine.dims:
        n = refine.sizes["start"]
        return [(f"{step} #{i + 1}", refine.isel(start=i)) for i in range(n)]
    return [(step, refine)]


def _start_point(r, attrs) -> tuple[float, float] | None:
    if "start_dtheta1" in r and "start_dtheta2" in r:
        return float(r["start_dtheta1"]), float(r["start_dtheta2"])
    try:
        s = json.loads(attrs.get("start", "null"))
        if isinstance(s, (list, tuple)) and len(s) == 2:
            return float(s[0]), float(s[1])
    except (TypeError, ValueError):
        pass
    return None


def minima_from(refines: Sequence) -> list[Minimum]:
    """The located minima of ``refine`` datasets (one per start), with their search paths."""
    out = []
    for refine in refines:
        for label, r in _split_starts(refine):
            p1 = np.asarray(r["iterate_dtheta1"].values, float) if "iterate_dtheta1" in r \
                else np.zeros(0)
            p2 = np.asarray(r["iterate_dtheta2"].values, float) if "iterate_dtheta2" in r \
                else np.zeros(0)
            keep = np.isfinite(p1) & np.isfinite(p2)          # multi-start padding is NaN
            out.append(Minimum(label, float(r["dtheta1"]), float(r["dtheta2"]),
                               float(r["error"]),
                               int(r["status"]) == Status.OK if "status" in r else True,
                               p1[keep], p2[keep], _start_point(r, refine.attrs)))
    return out


def _grid_title(g: GridData, what: str) -> str:
    if g.listed:
        return f"{what} at {count(g.listed, 'listed point')} of initial rates"
    return (f"{what} over a {g.dtheta1.size}×{g.dtheta2.size} grid of initial rates")


def scattered(g: GridData) -> bool:
    """Whether the grid is an explicit point list that leaves cells of the product of its
    values empty: its points are drawn as points (a list that fills its product, a grid
    written point by point, is drawn as cells)."""
    return bool(g.listed) and bool((g.status == MISSING).any())


#: how a listed point is drawn on a map (``s`` in points²): over the grid's least-error star
#: (zorder 6), whose tips show around it, under the refined minima's squares
POINT_MARKER = dict(marker="o", s=90, edgecolors="black", linewidths=0.6, zorder=6.5)


def draw_points(ax, g: GridData, values: np.ndarray, *, cmap: str, vmin: float, vmax: float,
                gid: str):
    """Draw a listed grid's points as markers: those with a value coloured by it (``values``
    indexed like ``g.error``; gid ``gid``), those without a gait in their category's colour
    and hatch (gid ``nogait_<category>``). Returns the coloured collection (for a colour
    bar) and the categories' legend entries."""
    has = np.isfinite(values) & (g.status != MISSING)
    i, j = np.nonzero(has)
    coloured = ax.scatter(g.dtheta1[i], g.dtheta2[j], c=values[i, j], cmap=cmap, vmin=vmin,
                          vmax=vmax, gid=gid, **POINT_MARKER)
    handles = []
    for key, mask, colour, hatch, label in g.category_masks():
        i, j = np.nonzero(mask)
        ax.scatter(g.dtheta1[i], g.dtheta2[j], color=colour, hatch=hatch,
                   gid=f"nogait_{key}", **POINT_MARKER)
        handles.append(Line2D([], [], ls="none", marker="o", ms=9, mfc=colour,
                              mec="black", label=label))
    return coloured, handles


# ----------------------------------------------------------------------------------------------
# intensity map (figs. 4, 9, 10)
# ----------------------------------------------------------------------------------------------
def plot_error_map(grid, refines: Sequence = (), *, vmax: float = 5.0, cmap: str = "magma",
                   show_paths: bool = True, profile: bool = True, title: str | None = None):
    """Intensity map of the gait error, truncated at ``vmax``, dark = small (study fig. 4).

    Parameters
    ----------
    grid : xarray.Dataset
        A ``grid`` dataset (docs/datasets.md).
    refines : sequence of xarray.Dataset
        ``refine`` datasets of the same study: their minima are marked with green squares and
        labelled with their position and error; their Nelder-Mead paths drawn dotted. Minima
        outside the grid's range are left out (the legend says how many). The grid's own
        least error is starred and labelled "least e" (with its value and times in the
        legend): it is a grid point, often of another kind than the refined gaits.
    vmax : float
        Errors above this are shown at the top colour (the study truncates at 5).
    profile : bool
        Add a side panel with the lowest error of each dtheta2 row (over dtheta1, log scale,
        untruncated): the valley floor, e.g. the study's "does not drop much below 1" (fig. 9).

    Returns
    -------
    matplotlib.figure.Figure
        Artists with ``gid``: ``error`` (the QuadMesh; its array is the clipped error,
        ``[i_dtheta2, i_dtheta1]``, masked where there is no gait), ``nogait_<category>``
        patches, ``minimum_<step>`` markers and ``label_<step>`` their numbers, ``path_<step>``
        lines, ``least_error`` (the star at the grid's least error) and its
        ``least_error_label``, ``row_minimum`` (the side panel's line: x the lowest error of
        each row, y dtheta2), ``row_minimum_points`` (its rows on no segment of that line, as
        dots), ``e_one`` (its dashed e = 1 line).
    """
    g = grid_arrays(grid)
    e1, e2 = cell_edges(g.dtheta1), cell_edges(g.dtheta2)
    clipped = np.ma.masked_invalid(np.minimum(g.error, vmax)).T
    profile = profile and bool(g.ok.any())       # no gait: no row has a lowest error
    with style():
        if profile:
            fig = new_figure(figsize=(8.8, 6.4))
            ax, axp = fig.subplots(1, 2, sharey=True, width_ratios=[4.2, 1.0])
        else:
            fig = new_figure(figsize=(7.4, 6.4))
            ax, axp = fig.add_subplot(), None
        handles = []
        if scattered(g):
            mesh, handles = draw_points(ax, g, np.minimum(g.error, vmax), cmap=cmap, vmin=0.0,
                                        vmax=vmax, gid="error")
        else:
            ax.grid(False)
            mesh = ax.pcolormesh(e1, e2, clipped, cmap=cmap, vmin=0.0, vmax=vmax,
                                 shading="flat", gid="error", rasterized=True, zorder=1)
            for key, mask, colour, hatch, label in g.category_masks():
                ax.add_patch(_hatch_patch(mask_path(mask, e1, e2), colour, hatch,
                                          f"nogait_{key}"))
                handles.append(_legend_patch(colour, hatch, label))
        cb = fig.colorbar(mesh, ax=[ax, axp] if profile else ax, extend="max", pad=0.02,
                          shrink=0.9)
        cb.set_label(f"{'section' if g.sequence else 'gait'} error e  {ERROR_UNITS}  (values above "
                     f"{vmax:g} shown as {vmax:g})")
        ax.set_xlim(e1[0], e1[-1])
        ax.set_ylim(e2[0], e2[-1])
        ax.set_xlabel(D1_LABEL)
        ax.set_ylabel(D2_LABEL)

        # located minima (green squares, as in the study) with their values, and the grid's
        # own least error (a star)
        every = minima_from(refines)
        shown = minima_shown(every, e1, e2)
        for m in shown:                       # search paths under every marker
            if show_paths and m.path1.size:
                ax.plot(m.path1, m.path2, ls=":", lw=1.2, color=MINIMUM_COLOUR, alpha=0.9,
                        gid=f"path_{m.label}", zorder=3)
            if show_paths and m.start is not None:
                ax.plot(*m.start, marker="o", ms=6, mfc="none", mec=MINIMUM_COLOUR, mew=1.5,
                        ls="none", zorder=4, gid=f"start_{m.label}")
        handles += mark_minima(fig, ax, shown, e1, e2, least_error(grid, g), values=True)
        if shown:
            outside = len(every) - len(shown)
            if outside:
                handles.append(Line2D([], [], ls="none", label=(
                    f"({count(outside, 'more located minimum', 'more located minima')} "
                    f"{'lies' if outside == 1 else 'lie'} outside this map)")))
            if show_paths:
                handles.append(Line2D([], [], marker="o", mfc="none", mec=MINIMUM_COLOUR,
                                      ls=":", color=MINIMUM_COLOUR,
                                      label="Nelder–Mead start (○) and best-vertex path"))
        if profile:
            _row_minimum_panel(axp, g)
        if handles:
            fig.legend(handles=handles, loc="outside lower center", ncols=1, frameon=False)
        what = "Sequence-gait section error e" if g.sequence else "Horizontal-gait error e"
        fig.suptitle(title or _grid_title(g, what), x=0.02,
                     ha="left", fontweight="bold")
        ax.set_title(run_label(grid), fontsize=8.5, fontweight="normal", loc="left")
    return fig


def plot_swap_time_map(grid, refines: Sequence = (), *, cmap: str = "viridis"):
    """The swap time ``t_switch`` over the grid, beside the error map: where it jumps, the
    swap comes on a later swing (link 1 swings back through the vertical first), and a small
    error there is a gait of another kind than the study's first-swing gait.

    The refined minima are marked and numbered as on the error map, and the grid's least
    error is starred.

    Returns
    -------
    matplotlib.figure.Figure
        Artists with ``gid``: ``t_switch`` (the QuadMesh; its array ``[i_dtheta2,
        i_dtheta1]``, masked where there is no gait), ``minimum_<step>`` markers,
        ``label_<step>`` their numbers, ``least_error``.

    Raises
    ------
    NothingToDraw
        No point of the grid has a gait.
    """
    g = grid_arrays(grid)
    e1, e2 = cell_edges(g.dtheta1), cell_edges(g.dtheta2)
    if "point" in grid.dims:
        ts = np.full(g.error.shape, np.nan)
        i1 = np.searchsorted(g.dtheta1, np.asarray(grid["dtheta1"].values, float))
        i2 = np.searchsorted(g.dtheta2, np.asarray(grid["dtheta2"].values, float))
        ts[i1, i2] = np.asarray(grid["t_switch"].values, float)
    else:
        ts = np.asarray(grid["t_switch"].transpose("dtheta1", "dtheta2").values, float)
    ts = np.where(g.status == Status.OK, ts, np.nan)
    if not np.isfinite(ts).any():
        raise NothingToDraw("no point of the grid has a gait, so there is no swap time (the "
                            "error map shows why)")
    with style():
        fig = new_figure(figsize=(7.4, 6.4))
        ax = fig.add_subplot()
        handles = []
        if scattered(g):
            mesh, handles = draw_points(ax, g, ts, cmap=cmap, vmin=float(np.nanmin(ts)),
                                        vmax=float(np.nanmax(ts)), gid="t_switch")
        else:
            ax.grid(False)
            mesh = ax.pcolormesh(e1, e2, np.ma.masked_invalid(ts).T, cmap=cmap,
                                 shading="flat", gid="t_switch", rasterized=True, zorder=1)
            for key, mask, colour, hatch, label in g.category_masks():
                ax.add_patch(_hatch_patch(mask_path(mask, e1, e2), colour, hatch,
                                          f"nogait_{key}"))
                handles.append(_legend_patch(colour, hatch, label))
        cb = fig.colorbar(mesh, ax=ax, pad=0.02, shrink=0.9)
        cb.set_label("swap time t_switch  [s]")
        # numbered as on the error map, so that the two figures read together
        handles += mark_minima(fig, ax, minima_shown(minima_from(refines), e1, e2), e1, e2,
                               least_error(grid, g), values=False)
        ax.set_xlim(e1[0], e1[-1])
        ax.set_ylim(e2[0], e2[-1])
        ax.set_xlabel(D1_LABEL)
        ax.set_ylabel(D2_LABEL)
        if handles:
            fig.legend(handles=handles, loc="outside lower center", ncols=1, frameon=False)
        where = (f"at {count(g.listed, 'listed point')}" if g.listed else "over the grid")
        fig.suptitle(f"Swap time {where}: a jump means a later swing", x=0.02, ha="left",
                     fontweight="bold")
        ax.set_title(run_label(grid), fontsize=8.5, fontweight="normal", loc="left")
    return fig


def minima_shown(every: Sequence[Minimum], e1: np.ndarray, e2: np.ndarray) -> list[Minimum]:
    """The minima inside the map's range, in the order they are numbered (1, 2, ...)."""
    return [m for m in every if e1[0] <= m.dtheta1 <= e1[-1] and e2[0] <= m.dtheta2 <= e2[-1]]


@dataclass
class LeastError:
    """The grid point with the least error (as numpy's argmin: the first of ties)."""

    dtheta1: float
    dtheta2: float
    error: float
    t_switch: float
    t_motor: float


def least_error(grid, g: GridData) -> LeastError | None:
    """The grid's least error and where it lies, None when no point has a gait."""
    if not g.ok.any():
        return None
    i, j = np.unravel_index(np.nanargmin(np.where(g.ok, g.error, np.nan)), g.error.shape)
    d1, d2 = float(g.dtheta1[i]), float(g.dtheta2[j])
    times = []
    for name in ("t_switch", "t_motor"):
        if name not in grid:
            times.append(math.nan)
        elif "point" in grid.dims:
            at = np.flatnonzero((grid["dtheta1"].values == d1) & (grid["dtheta2"].values == d2))
            times.append(float(grid[name].values[at[0]]))
        else:
            times.append(float(grid[name].sel(dtheta1=d1, dtheta2=d2)))
    return LeastError(d1, d2, float(g.error[i, j]), *times)


#: how the grid's least error is marked on the maps
LEAST_MARKER = dict(marker="*", ms=15, mfc="white", mec="black", mew=1.0, ls="none")


def mark_minima(fig, ax, shown: Sequence[Minimum], e1: np.ndarray, e2: np.ndarray,
                least: LeastError | None, *, values: bool) -> list:
    """Mark the refined minima (green squares, numbered 1, 2, ... in ``shown``'s order) and
    the grid's least error (a white star labelled "least e"); returns their legend entries,
    with the values (``values``) or pointing to the error map for them. The star lies under
    the squares (a minimum on the grid's least error still shows), the labels over both,
    each placed beside its marker clear of every marker and earlier label."""
    lo1, hi1, lo2, hi2 = e1[0], e1[-1], e2[0], e2[-1]
    points = [(m.dtheta1, m.dtheta2) for m in shown]
    sizes = [label_size(str(k), 9) for k in range(1, len(shown) + 1)]
    if least is not None:
        points.append((least.dtheta1, least.dtheta2))
        sizes.append(label_size("least e", 8))
    box = ax.get_position()
    axes_pt = (box.width * fig.get_figwidth() * 72.0, box.height * fig.get_figheight() * 72.0)
    offsets = label_offsets([((x - lo1) / (hi1 - lo1), (y - lo2) / (hi2 - lo2))
                             for x, y in points], sizes, axes_pt,
                            marker_pt=[8.0] * len(shown) + [15.0] * (least is not None))
    outline = [withStroke(linewidth=2.5, foreground="black")]
    handles = []
    for k, (m, off) in enumerate(zip(shown, offsets), 1):
        # the square marks the minimum; its number keys the value in the legend (labels
        # beside close minima would cover each other's markers)
        ax.plot(m.dtheta1, m.dtheta2, marker="s", ms=8, mfc=MINIMUM_COLOUR, mec="black",
                mew=1.0, ls="none", zorder=7, gid=f"minimum_{m.label}", clip_on=False)
        ax.annotate(str(k), (m.dtheta1, m.dtheta2), xytext=off, ha="left", va="bottom",
                    textcoords="offset points", fontsize=9, fontweight="bold",
                    color="white", path_effects=outline, zorder=9, gid=f"label_{m.label}",
                    arrowprops=None if max(abs(off[0]), abs(off[1])) < 12 else dict(
                        arrowstyle="-", color="white", lw=0.8, shrinkA=0, shrinkB=4))
        if not values:
            what = "as numbered on the error map"
        elif m.ok and finite(m.error):
            what = f"e = {m.error:.2g} at ({m.dtheta1:.3f}, {m.dtheta2:.3f})"
        else:
            what = f"no gait at ({m.dtheta1:.3f}, {m.dtheta2:.3f}): the search found none"
        handles.append(Line2D([], [], marker="s", ms=8, mfc=MINIMUM_COLOUR, mec="black",
                              ls="none", label=f"{k}: {m.label}, {what}"))
    if least is not None:
        ax.plot(least.dtheta1, least.dtheta2, zorder=6, gid="least_error", clip_on=False,
                **LEAST_MARKER)
        ax.annotate("least e", (least.dtheta1, least.dtheta2), xytext=offsets[-1], ha="left",
                    va="bottom", textcoords="offset points", fontsize=8, fontweight="bold",
                    color="white", path_effects=outline, zorder=9, gid="least_error_label")
        if values:
            times = ""
            if finite(least.t_switch) and finite(least.t_motor):
                times = (f", its swap at {least.t_switch:.3f} s, motor on for "
                         f"{duration(least.t_motor)}")
            text = (f"least e: the grid's least error, e = {least.error:.2g} at "
                    f"({least.dtheta1:.3f}, {least.dtheta2:.3f})\n{times[2:] + ' ' if times else ''}"
                    "(a point of the grid, not refined)")
        else:
            text = "least e: the grid's least error (its value on the error map)"
        handles.append(Line2D([], [], label=text, **LEAST_MARKER))
    return handles


def label_size(text: str, fontsize: float) -> tuple[float, float]:
    """Roughly the size ``(width, height)`` [pt] of a bold label ``text`` at ``fontsize``."""
    return 0.68 * fontsize * len(text) + 2.0, 0.95 * fontsize + 2.0


def label_offsets(points, sizes, axes_pt, marker_pt, gap: float = 3.0
                  ) -> list[tuple[float, float]]:
    """Offsets [pt] of the lower-left corners of labels of ``sizes`` (``(width, height)``
    [pt]) from their markers at ``points`` (axes fractions; markers ``marker_pt`` wide):
    beside the marker where the label stays inside the axes (``axes_pt``, its size [pt])
    and clear of every marker and of the labels placed before it; farther out when the
    near places are taken; the first place inside the axes when none is clear."""
    w, h = axes_pt
    centres = [(x * w, y * h) for x, y in points]
    markers = [(cx - m / 2, cy - m / 2, cx + m / 2, cy + m / 2)
               for (cx, cy), m in zip(centres, marker_pt)]

    def overlap(a, b) -> bool:
        return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]

    placed, out = [], []
    for (cx, cy), (lw, lh), m in zip(centres, sizes, marker_pt):
        r = m / 2 + gap
        candidates = []
        for d in (0.0, 12.0, 26.0):                  # beside the marker, then farther out
            candidates += [(r + d, -lh / 2), (-r - d - lw, -lh / 2), (r + d, r + d - lh / 2),
                           (-r - d - lw, r + d - lh / 2), (r + d, -r - d - lh / 2),
                           (-r - d - lw, -r - d - lh / 2), (-lw / 2, r + d),
                           (-lw / 2, -r - d - lh)]
        inside = [(dx, dy) for dx, dy in candidates
                  if 0 <= cx + dx and cx + dx + lw <= w and 0 <= cy + dy and cy + dy + lh <= h]
        choice = None
        for dx, dy in inside:
            rect = (cx + dx, cy + dy, cx + dx + lw, cy + dy + lh)
            if not any(overlap(rect, o) for o in markers + placed):
                choice = (dx, dy)
                break
        if choice is None:
            choice = inside[0] if inside else candidates[0]
        out.append(choice)
        placed.append((cx + choice[0], cy + choice[1], cx + choice[0] + lw,
                       cy + choice[1] + lh))
    return out


def row_minimum(g: GridData) -> np.ndarray:
    """Lowest error of each dtheta2 row over dtheta1 (NaN where the row has no gait)."""
    e = np.where(np.isfinite(g.error), g.error, np.inf).min(axis=0)
    return np.where(np.isfinite(e), e, np.nan)


def _row_minimum_panel(axp, g: GridData) -> None:
    low = row_minimum(g)
    axp.plot(low, g.dtheta2, color="black", lw=1.2, gid="row_minimum")
    # a row whose neighbours have no gait (or the grid's only row) is on no line segment
    ok = np.isfinite(low)
    alone = ok & ~np.r_[False, ok[:-1]] & ~np.r_[ok[1:], False]
    axp.plot(low[alone], g.dtheta2[alone], ls="none", marker="o", ms=3.5, color="black",
             gid="row_minimum_points")
    axp.set_xscale("log")
    axp.xaxis.set_minor_formatter(NullFormatter())  # within a decade they overlap
    # e = 1: the 2009 study's fig. 9 reads its valley floor against it
    axp.axvline(1.0, color="0.5", ls="--", lw=0.8, gid="e_one")
    axp.annotate("e = 1", (1.0, 1.0), xycoords=("data", "axes fraction"), xytext=(-3, -3),
                 textcoords="offset points", rotation=90, ha="right", va="top", fontsize=7.5,
                 color="0.35", gid="e_one_label")
    axp.set_xlabel("lowest e of each\n" r"$\dot\theta_2$ row" "\n" + ERROR_UNITS)
    axp.tick_params(labelleft=False)
    finite = low[np.isfinite(low) & (low > 0)]
    if finite.size:
        # whole decades around the values and e = 1, with a decade left of e = 1 for its label
        axp.set_xlim(10 ** min(np.floor(np.log10(finite.min())), -1.0),
                     10 ** np.ceil(np.log10(max(finite.max(), 1.0))) * 1.0001)


# ----------------------------------------------------------------------------------------------
# 3-D surface (fig. 3)
# ----------------------------------------------------------------------------------------------
def plot_error_surface(grid, *, max_cells: int = 250, cmap: str = "magma",
                       elev: float = 50.0, azim: float = -118.0, title: str | None = None):
    """3-D surface of sqrt(error) over (dtheta1, dtheta2) (study fig. 3).

    Points without a gait form a flat floor at 0 in their category colours (the study's flat
    "not enough energy" region: each point's cell, as on the map), with a legend. The surface
    (:func:`continuous_surface`) joins neighbouring points with a gait, and never across a
    jump of sqrt(e) by more than a tenth of its range (the gait's event sequence changes
    there: a gap, not a wall); regions of a few cells, too thin for the grid to resolve, are
    left to the map. Points with a gait that belong to no drawn cell (a grid with one value
    along an axis, a point among points without a gait) are drawn as dots at their height.
    Grids with more than ``max_cells`` points along an axis are drawn with every n-th point
    (a uniform stride, no averaging), so the surface keeps the data's own values.

    Returns a Figure whose surface has ``gid`` ``sqrt_error``, its dots ``sqrt_error_points``
    and floors ``floor_<category>``.

    Raises
    ------
    NothingToDraw
        No point of the grid has a gait.
    """
    g = grid_arrays(grid)
    if not g.ok.any():
        raise NothingToDraw("no point of the grid has a gait, so there is no error to draw a "
                            "surface of (the error map shows why)")
    rs = -(-g.dtheta1.size // max_cells)          # uniform strides (ceil division)
    cs = -(-g.dtheta2.size // max_cells)
    d1, d2 = g.dtheta1[::rs], g.dtheta2[::cs]
    X, Y = np.meshgrid(d1, d2, indexing="ij")
    Z = np.sqrt(g.error[::rs, ::cs])
    zmax = float(np.nanmax(Z)) if np.isfinite(Z).any() else 0.0
    zmax = zmax if zmax > 0 else 1.0               # every error 0: a flat surface at 0
    e1, e2 = cell_edges(d1), cell_edges(d2)
    with style():
        fig = new_figure(figsize=(7.6, 6.2))
        ax = fig.add_subplot(projection="3d", computed_zorder=False)
        handles = []
        for key, mask, colour, hatch, label in g.category_masks():
            floor = floor_tiles(mask[::rs, ::cs], e1, e2)
            # edges in the face colour: no seams between the tiles
            floor.set(facecolor=colour, edgecolor=colour, linewidth=0.4, gid=f"floor_{key}",
                      zorder=1, rasterized=True)
            ax.add_collection3d(floor)
            handles.append(Patch(facecolor=colour, edgecolor="#42526e", label=label))
        surf, loose = continuous_surface(X, Y, Z, cmap=cmap, vmax=zmax, jump=0.1 * zmax)
        surf.set(gid="sqrt_error", zorder=2, rasterized=True)
        ax.add_collection3d(surf)
        if min(Z.shape) == 1 and Z.size > 1:
            # one value along an axis: the surface is a curve along the other
            line = np.ravel(Z).copy()
            with np.errstate(invalid="ignore"):
                line[1:][np.abs(np.diff(line)) > 0.1 * zmax] = np.nan    # not across a jump
            ax.plot(np.ravel(X), np.ravel(Y), np.where(np.isfinite(np.ravel(Z)), line, np.nan),
                    color="0.25", lw=1.2, zorder=3, gid="sqrt_error_line")
        if loose.any():
            ax.scatter(X[loose], Y[loose], Z[loose], c=Z[loose], cmap=cmap, vmin=0.0,
                       vmax=zmax, s=16 if Z.size <= 400 else 4, depthshade=False,
                       edgecolors="black", linewidths=0.3, zorder=3, gid="sqrt_error_points")
            handles.append(Line2D([], [], marker="o", ls="none", mfc="0.4", mec="black",
                                  label=f"points with a gait in no whole cell of the surface "
                                        f"({int(loose.sum())})"))
        cb = fig.colorbar(ScalarMappable(Normalize(0.0, zmax), cmap), ax=ax, shrink=0.6,
                          pad=0.08)
        cb.set_label(r"$\sqrt{e}$  (e in " + ERROR_UNITS[1:-1] + ")")
        ax.set_xlabel(D1_LABEL, labelpad=8)
        ax.set_ylabel(D2_LABEL, labelpad=8)
        ax.set_zlabel(r"$\sqrt{e}$", labelpad=6)
        ax.set_xlim(e1[0], e1[-1])           # every point's cell, as on the map
        ax.set_ylim(e2[0], e2[-1])
        ax.set_zlim(0.0, zmax)
        ax.view_init(elev=elev, azim=azim)
        if handles:
            fig.legend(handles=handles, loc="outside lower center", ncols=1, frameon=False)
        fig.suptitle(title or _grid_title(g, "Square root of the "
                                                + ("section" if g.sequence else "gait")
                                                + " error"), x=0.02,
                     ha="left", fontweight="bold")
        ax.set_title(run_label(grid), fontsize=8.5, fontweight="normal", loc="left")
    return fig


def floor_tiles(mask: np.ndarray, e1: np.ndarray, e2: np.ndarray) -> Poly3DCollection:
    """Flat tiles at height 0 over the cells of the points where ``mask[i1, i2]``
    (consecutive cells along dtheta2 merged into one tile)."""
    tiles = [[(x0, y0, 0.0), (x1, y0, 0.0), (x1, y1, 0.0), (x0, y1, 0.0)]
             for x0, x1, y0, y1 in cell_runs(mask, e1, e2)]
    return Poly3DCollection(tiles, linewidths=0.0)


#: corners of the cell (i, j) of a grid, counter-clockwise: (i, j), (i+1, j), (i+1, j+1),
#: (i, j+1)
_CORNERS = ((slice(None, -1), slice(None, -1)), (slice(1, None), slice(None, -1)),
            (slice(1, None), slice(1, None)), (slice(None, -1), slice(1, None)))


def continuous_surface(X: np.ndarray, Y: np.ndarray, Z: np.ndarray, *, cmap: str,
                       vmax: float, jump: float, min_region: float = 5e-4
                       ) -> tuple[Poly3DCollection, np.ndarray]:
    """The surface ``Z(X, Y)`` drawn where it is continuous, and the points it leaves out.

    A cell is drawn whole when its four corners are finite and span at most ``jump`` in Z;
    otherwise its triangle of three such corners, if it has one (so that the surface's edge
    along a gap or the grid's border runs across cells, not round them). Connected regions of
    fewer than ``min_region`` times the grid's cells (at least 2) are left out: a strip the
    grid cannot resolve. Faces are coloured by their mean height (``cmap`` over
    ``0..vmax``) and shaded by a light from the upper left, as ``plot_surface`` shades.

    Returns the collection and the mask of finite points in no drawn face.
    """
    cells = np.stack([np.stack([A[c] for c in _CORNERS], axis=-1) for A in (X, Y, Z)],
                     axis=-1)                                # (n1 - 1, n2 - 1, 4, 3)
    z = cells[..., 2]
    finite = np.isfinite(z)

    def good(corners: list[int]) -> np.ndarray:
        zz = z[..., corners]
        with np.errstate(invalid="ignore"):
            span = np.max(zz, axis=-1) - np.min(zz, axis=-1)
        return finite[..., corners].all(axis=-1) & (span <= jump)

    whole = good([0, 1, 2, 3])
    triangles = {k: good([j for j in range(4) if j != k]) & ~whole for k in range(4)}
    drawn = whole | np.logical_or.reduce(list(triangles.values()))
    if drawn.size:
        labels, n = ndimage.label(drawn)
        sizes = ndimage.sum(drawn, labels, index=np.arange(1, n + 1))
        keep = np.isin(labels, 1 + np.flatnonzero(sizes >= max(2, min_region * drawn.size)))
    else:
        keep = drawn
    covered = np.zeros(Z.shape, bool)
    quads = cells[whole & keep]                                   # (n, 4, 3)
    tris = [cells[m & keep][:, [j for j in range(4) if j != k]] for k, m in triangles.items()]
    tris = np.concatenate(tris) if tris else np.zeros((0, 3, 3))  # (m, 3, 3)
    for k, m in triangles.items():
        for j in range(4):
            if j != k:
                covered[_CORNERS[j]] |= m & keep
    for j in range(4):
        covered[_CORNERS[j]] |= whole & keep
    loose = np.isfinite(Z) & ~covered
    if not len(quads) and not len(tris):
        return Poly3DCollection([], linewidths=0.15), loose
    z_mean = np.concatenate([quads[:, :, 2].mean(axis=1), tris[:, :, 2].mean(axis=1)])
    colours = colormaps[cmap](Normalize(0.0, vmax)(z_mean))
    normals = np.concatenate([np.cross(quads[:, 2] - quads[:, 0], quads[:, 3] - quads[:, 1]),
                              np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    # the sign of a normal is arbitrary: light the side facing up
    normals *= np.sign(normals[:, 2:3] + (normals[:, 2:3] == 0))
    shade = LightSource(azdeg=225, altdeg=19.4712).shade_normals(normals, fraction=1.0)
    colours[:, :3] *= (0.35 + 0.65 * shade)[:, None]
    faces = list(quads) + list(tris)
    return Poly3DCollection(faces, facecolors=colours, edgecolors=(0, 0, 0, 0.15),
                            linewidths=0.15), loose


# ----------------------------------------------------------------------------------------------
# Nelder-Mead convergence of a refine step
# ----------------------------------------------------------------------------------------------
def plot_refine_convergence(refine):
    """Best-vertex error per Nelder-Mead iteration of a ``refine`` dataset (log scale), one
    line per start, the iterations as the dataset holds them: iterate 0 is the start (ringed),
    so a search of n iterations has n + 1 iterates.

    Shows where the search stalls (the tick-quantised error surface stops the simplex above
    zero). Lines have ``gid`` ``iterate_error`` (one start) or ``iterate_error_<i>``; the
    start's marker ``start_error`` (or ``start_error_<i>``).

    Raises
    ------
    NothingToDraw
        No iterate of any start has a gait (so no error to draw).
    """
    starts = _split_starts(refine)
    mins = minima_from([refine])
    series = []
    for label, r in starts:
        err = np.asarray(r["iterate_error"].values, float)
        it = np.asarray(r["iteration"].values if "iteration" in r.coords
                        else np.arange(err.size), float)
        real = np.ones(err.size, bool)
        if "iterate_nfev" in r:                         # multi-start padding is -1
            real = np.asarray(r["iterate_nfev"].values) >= 0
        series.append((label, it, err, real))
    if not any(np.any(np.isfinite(e) & (e > 0) & real) for _, _, e, real in series):
        raise NothingToDraw("no iterate of the search has a gait, so there is no error to "
                            "draw (every point it tried failed)")
    with style():
        fig = new_figure(figsize=(7.0, 4.6))
        ax = fig.add_subplot()
        counts = []
        for k, ((label, it, err, real), m) in enumerate(zip(series, mins)):
            keep = np.isfinite(err) & (err > 0) & real
            n_it = int(real.sum()) - 1          # iterate 0 is the start
            counts.append(n_it)
            start = f"start ({m.start[0]:.3f}, {m.start[1]:.3f}) → " if m.start else ""
            found = (f"e = {m.error:.3g} at ({m.dtheta1:.4f}, {m.dtheta2:.4f})"
                     if finite(m.error) else "no gait found")
            failed = int((real & ~keep).sum())
            line, = ax.plot(it[keep], err[keep], marker=".",
                            gid="iterate_error" if len(starts) == 1 else f"iterate_error_{k}",
                            label=f"{label}: {start}{found}, {count(n_it, 'iteration')}"
                                  + (f" ({count(failed, 'iterate')} without a gait, not "
                                     "drawn)" if failed else ""))
            if keep[0]:
                ax.plot(it[:1], err[:1], marker="o", ms=9, mfc="none", mec=line.get_color(),
                        mew=1.5, ls="none",
                        gid="start_error" if len(starts) == 1 else f"start_error_{k}")
        ax.plot([], [], marker="o", ms=9, mfc="none", mec="0.3", mew=1.5, ls="none",
                label="iterate 0: the start")
        ax.set_yscale("log")
        readable_log_axis(ax)
        ax.set_xlabel("Nelder–Mead iteration (0: the start)")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
        ax.set_ylabel(("section" if is_sequence(refine) else "gait")
                      + f" error e of the best vertex  {ERROR_UNITS}")
        ax.legend(loc="upper right", fontsize=8)
        conv = refine["converged"] if "converged" in refine else refine.attrs.get("converged")
        conv = np.atleast_1d(np.asarray(getattr(conv, "values", conv) if conv is not None
                                        else [], dtype=float))
        after = f" after {count(counts[0], 'iteration')}" if len(counts) == 1 else ""
        note = ("" if conv.size == 0 else f"converged (xatol, fatol met){after}"
                if np.all(conv == 1) else f"stopped at the iteration limit{after}"
                if np.all(conv == 0) else f"{int(np.sum(conv == 1))} of "
                f"{count(conv.size, 'start')} converged")
        fig.suptitle(f"Nelder–Mead refinement {refine.attrs.get('step_name', '')}", x=0.02,
                     ha="left", fontweight="bold")
        ax.set_title((note + "\n" if note else "") + run_label(refine), fontsize=8.5,
                     fontweight="normal", loc="left")
    return fig
