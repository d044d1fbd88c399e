"""Error maps of a grid dataset: the 3-D surface (study fig. 3) and the intensity map (figs. 4,
9 and 10).

Grid points without a gait (``status != 0``, the study's "not enough energy" region and other
failures) have no error value; they are drawn as their own categories, never as numbers:
hatched patches of distinct colours on the map, a flat floor of the same colours under the
surface.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib import colormaps
from matplotlib.cm import ScalarMappable
from matplotlib.colors import LightSource, Normalize
from matplotlib.lines import Line2D
from matplotlib.patches import Patch, PathPatch
from matplotlib.patheffects import withStroke
from matplotlib.path import Path as MplPath
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from ..kernel import layout as L
from .common import ERROR_UNITS, MINIMUM_COLOUR, new_figure, run_label, status_name, style
from .drawing import Drawing, Folder

D1_LABEL = r"initial $\dot\theta_1$  [rad s$^{-1}$]"
D2_LABEL = r"initial $\dot\theta_2$  [rad s$^{-1}$]"

#: No-gait categories: (key, status codes or None for "every other failure", colour, hatch,
#: legend text). The first two are the study's flat "not enough energy" region.
NO_GAIT = (
    ("unreachable", (L.ST_UNREACHABLE,), "#7f98bd", "///",
     "no gait: B cannot reach A's height (energy bound, not integrated)"),
    ("no_switch", (L.ST_NO_SWITCH,), "#b3d1ee", "\\\\\\",
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

    @property
    def ok(self) -> np.ndarray:
        return (self.status == L.ST_OK) & np.isfinite(self.error)

    def category_masks(self) -> list[tuple[str, np.ndarray, str, str, str]]:
        """``(key, mask, colour, hatch, label)`` for each no-gait category present."""
        failed = (self.status != L.ST_OK) & (self.status != MISSING)
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
                out.append((key, mask, colour, hatch, f"{label} ({int(mask.sum())} points)"))
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
    err = np.where(st == L.ST_OK, err, np.nan)    # a no-gait point never shows a number
    return GridData(d1, d2, err, st, is_sequence(ds))


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


def mask_path(mask: np.ndarray, e1: np.ndarray, e2: np.ndarray) -> MplPath:
    """One compound path of the cells where ``mask[i1, i2]`` (x = dtheta1, y = dtheta2),
    consecutive cells along dtheta2 merged into one rectangle."""
    verts, codes = [], []
    for i in range(mask.shape[0]):
        col = np.concatenate([[False], mask[i], [False]])
        starts = np.flatnonzero(~col[:-1] & col[1:])
        stops = np.flatnonzero(col[:-1] & ~col[1:])
        for a, b in zip(starts, stops):
            x0, x1, y0, y1 = e1[i], e1[i + 1], e2[a], e2[b]
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
                               int(r["status"]) == L.ST_OK if "status" in r else True,
                               p1[keep], p2[keep], _start_point(r, refine.attrs)))
    return out


def _grid_title(g: GridData, what: str) -> str:
    return (f"{what} over a {g.dtheta1.size}×{g.dtheta2.size} grid of initial rates")


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
        outside the grid's range are left out (the legend says how many).
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
        patches, ``minimum_<step>`` markers, ``path_<step>`` lines, ``row_minimum`` (the side
        panel's line: x the lowest error of each row, y dtheta2).
    """
    g = grid_arrays(grid)
    e1, e2 = cell_edges(g.dtheta1), cell_edges(g.dtheta2)
    clipped = np.ma.masked_invalid(np.minimum(g.error, vmax)).T
    with style():
        if profile:
            fig = new_figure(figsize=(8.8, 6.4))
            ax, axp = fig.subplots(1, 2, sharey=True, width_ratios=[4.2, 1.0])
        else:
            fig = new_figure(figsize=(7.4, 6.4))
            ax, axp = fig.add_subplot(), None
        ax.grid(False)
        mesh = ax.pcolormesh(e1, e2, clipped, cmap=cmap, vmin=0.0, vmax=vmax, shading="flat",
                             gid="error", rasterized=True, zorder=1)
        cb = fig.colorbar(mesh, ax=[ax, axp] if profile else ax, extend="max", pad=0.02,
                          shrink=0.9)
        cb.set_label(f"{'section' if g.sequence else 'gait'} error e  {ERROR_UNITS}  (values above "
                     f"{vmax:g} shown as {vmax:g})")
        handles = []
        for key, mask, colour, hatch, label in g.category_masks():
            ax.add_patch(_hatch_patch(mask_path(mask, e1, e2), colour, hatch, f"nogait_{key}"))
            handles.append(_legend_patch(colour, hatch, label))
        ax.set_xlim(e1[0], e1[-1])
        ax.set_ylim(e2[0], e2[-1])
        ax.set_xlabel(D1_LABEL)
        ax.set_ylabel(D2_LABEL)

        # located minima (green squares, as in the study) with their values
        lo1, hi1, lo2, hi2 = e1[0], e1[-1], e2[0], e2[-1]
        every = minima_from(refines)
        shown = [m for m in every if lo1 <= m.dtheta1 <= hi1 and lo2 <= m.dtheta2 <= hi2]
        for m in shown:                       # search paths under every marker
            if show_paths and m.path1.size:
                ax.plot(m.path1, m.path2, ls=":", lw=1.2, color=MINIMUM_COLOUR, alpha=0.9,
                        gid=f"path_{m.label}", zorder=3)
            if show_paths and m.start is not None:
                ax.plot(*m.start, marker="o", ms=6, mfc="none", mec=MINIMUM_COLOUR, mew=1.5,
                        ls="none", zorder=4, gid=f"start_{m.label}")
        outline = [withStroke(linewidth=2.5, foreground="black")]
        offsets = _label_offsets([((m.dtheta1 - lo1) / (hi1 - lo1),
                                   (m.dtheta2 - lo2) / (hi2 - lo2))
                                  for m in shown], fig.get_size_inches())
        for k, (m, off) in enumerate(zip(shown, offsets), 1):
            # the square marks the minimum; its number keys the value in the legend (labels
            # beside close minima would cover each other's markers)
            ax.plot(m.dtheta1, m.dtheta2, marker="s", ms=8, mfc=MINIMUM_COLOUR, mec="black",
                    mew=1.0, ls="none", zorder=6, gid=f"minimum_{m.label}", clip_on=False)
            ax.annotate(str(k), (m.dtheta1, m.dtheta2), xytext=off,
                        textcoords="offset points", fontsize=9, fontweight="bold",
                        color="white", path_effects=outline, zorder=7, gid=f"label_{m.label}",
                        arrowprops=None if off == (6, 5) else dict(
                            arrowstyle="-", color="white", lw=0.8, shrinkA=0, shrinkB=4))
            handles.append(Line2D(
                [], [], marker="s", ms=8, mfc=MINIMUM_COLOUR, mec="black", ls="none",
                label=f"{k}: {m.label}, e = {m.error:.2g} at "
                      f"({m.dtheta1:.3f}, {m.dtheta2:.3f})" + ("" if m.ok else " (no gait)")))
        if shown:
            outside = len(every) - len(shown)
            if outside:
                handles.append(Line2D([], [], ls="none", label=f"({outside} more located "
                                                               "minima lie outside this map)"))
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

    Returns
    -------
    matplotlib.figure.Figure
        Artists with ``gid``: ``t_switch`` (the QuadMesh; its array ``[i_dtheta2,
        i_dtheta1]``, masked where there is no gait), ``minimum_<step>`` markers.
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
    ts = np.where(g.status == L.ST_OK, ts, np.nan)
    with style():
        fig = new_figure(figsize=(7.4, 6.4))
        ax = fig.add_subplot()
        ax.grid(False)
        mesh = ax.pcolormesh(e1, e2, np.ma.masked_invalid(ts).T, cmap=cmap, shading="flat",
                             gid="t_switch", rasterized=True, zorder=1)
        cb = fig.colorbar(mesh, ax=ax, pad=0.02, shrink=0.9)
        cb.set_label("swap time t_switch  [s]")
        handles = []
        for key, mask, colour, hatch, label in g.category_masks():
            ax.add_patch(_hatch_patch(mask_path(mask, e1, e2), colour, hatch, f"nogait_{key}"))
            handles.append(_legend_patch(colour, hatch, label))
        for m in minima_from(refines):
            if e1[0] <= m.dtheta1 <= e1[-1] and e2[0] <= m.dtheta2 <= e2[-1]:
                ax.plot(m.dtheta1, m.dtheta2, marker="s", ms=8, mfc=MINIMUM_COLOUR,
                        mec="black", mew=1.0, ls="none", zorder=6, gid=f"minimum_{m.label}")
        if any(m for m in minima_from(refines)):
            handles.append(Line2D([], [], marker="s", ms=8, mfc=MINIMUM_COLOUR, mec="black",
                                  ls="none", label="refined minima (as on the error map)"))
        ax.set_xlim(e1[0], e1[-1])
        ax.set_ylim(e2[0], e2[-1])
        ax.set_xlabel(D1_LABEL)
        ax.set_ylabel(D2_LABEL)
        if handles:
            fig.legend(handles=handles, loc="outside lower center", ncols=1, frameon=False)
        fig.suptitle("Swap time over the grid: a jump means a later swing", x=0.02, ha="left",
                     fontweight="bold")
        ax.set_title(run_label(grid), fontsize=8.5, fontweight="normal", loc="left")
    return fig


def _label_offsets(points, fig_size, min_sep: float = 13.0) -> list[tuple[int, int]]:
    """Offsets [points] for the number labels of markers at ``points`` (axes fractions):
    beside the marker, moved around it when that would overlap an earlier label or marker."""
    w, h = 0.7 * fig_size[0] * 72.0, 0.7 * fig_size[1] * 72.0    # axes size, roughly [pt]
    markers = [(x * w, y * h) for x, y in points]
    # beside the marker first (right, left), then above and below it
    candidates = [(6, 5), (-15, 5), (12, -5), (-22, -5), (6, -15), (-15, -15), (6, 20),
                  (-15, 20), (20, 14), (-28, 14), (6, -30), (-15, -30), (20, 28), (-28, 28)]
    placed, out = [], []
    for mx, my in markers:
        choice = None
        for dx, dy in candidates:
            cx, cy = mx + dx + 3, my + dy + 4                 # centre of the digit
            inside = 6.0 <= cx <= w - 6.0 and 6.0 <= cy <= h - 6.0
            clear = all(np.hypot(cx - px, cy - py) >= min_sep for px, py in placed) and \
                all(np.hypot(cx - ox, cy - oy) >= 9.0 for ox, oy in markers)
            if inside and clear:
                choice = (dx, dy)
                break
        if choice is None:          # crowded: the first position inside the axes
            choice = next(((dx, dy) for dx, dy in candidates
                           if 6.0 <= mx + dx + 3 <= w - 6.0 and 6.0 <= my + dy + 4 <= h - 6.0),
                          candidates[0])
        out.append(choice)
        placed.append((mx + choice[0] + 3, my + choice[1] + 4))
    return out


def row_minimum(g: GridData) -> np.ndarray:
    """Lowest error of each dtheta2 row over dtheta1 (NaN where the row has no gait)."""
    e = np.where(np.isfinite(g.error), g.error, np.inf).min(axis=0)
    return np.where(np.isfinite(e), e, np.nan)


def _row_minimum_panel(axp, g: GridData) -> None:
    low = row_minimum(g)
    axp.plot(low, g.dtheta2, color="black", lw=1.2, gid="row_minimum")
    axp.set_xscale("log")
    axp.axvline(1.0, color="0.5", ls="--", lw=0.8)
    axp.set_xlabel("lowest e of each\n" r"$\dot\theta_2$ row  [1]")
    axp.tick_params(labelleft=False)
    finite = low[np.isfinite(low) & (low > 0)]
    if finite.size:
        axp.set_xlim(10 ** np.floor(np.log10(finite.min())),
                     10 ** np.ceil(np.log10(max(finite.max(), 1.0))) * 1.0001)


# ----------------------------------------------------------------------------------------------
# 3-D surface (fig. 3)
# ----------------------------------------------------------------------------------------------
def plot_error_surface(grid, *, max_cells: int = 150, cmap: str = "magma",
                       elev: float = 50.0, azim: float = -118.0, title: str | None = None):
    """3-D surface of sqrt(error) over (dtheta1, dtheta2) (study fig. 3).

    Points without a gait form a flat floor at 0 in their category colours (the study's flat
    "not enough energy" region), with a legend; the surface itself is only drawn where there is
    a gait, and not across a jump of sqrt(e) by more than a tenth of its range between
    neighbours (the gait's event sequence changes there: a gap, not a wall). The surface is
    drawn cell by cell, only cells whose four corners all carry a value (matplotlib's
    ``plot_surface`` keeps the triangles of cells with a missing corner, which line every gap
    with teeth). Grids with more than ``max_cells`` points along an axis are drawn with every
    n-th point (a uniform stride, no averaging), so the surface keeps the data's own values.

    Returns a Figure whose surface has ``gid`` ``sqrt_error`` and floors ``floor_<category>``.
    """
    g = grid_arrays(grid)
    rs = -(-g.dtheta1.size // max_cells)          # uniform strides (ceil division)
    cs = -(-g.dtheta2.size // max_cells)
    X, Y = np.meshgrid(g.dtheta1[::rs], g.dtheta2[::cs], indexing="ij")
    Z = np.sqrt(g.error[::rs, ::cs])
    zmax = float(np.nanmax(Z)) if np.isfinite(Z).any() else 1.0
    # a surface drawn across a jump of the error is a wall of thin teeth; leave a gap there
    # instead: the higher side of every jump is not drawn
    Z = np.where(jump_points(Z, 0.1 * zmax), np.nan, Z)
    with style():
        fig = new_figure(figsize=(7.6, 6.2))
        ax = fig.add_subplot(projection="3d", computed_zorder=False)
        handles = []
        for key, mask, colour, hatch, label in g.category_masks():
            Zf = np.where(mask[::rs, ::cs], 0.0, np.nan)
            ax.plot_surface(X, Y, Zf, color=colour, rstride=1, cstride=1, linewidth=0,
                            antialiased=False, shade=False, gid=f"floor_{key}", zorder=1)
            handles.append(Patch(facecolor=colour, edgecolor="#42526e", label=label))
        surf = whole_cell_surface(X, Y, Z, cmap=cmap, vmax=zmax)
        surf.set_gid("sqrt_error")
        surf.set_zorder(2)
        ax.add_collection3d(surf)
        cb = fig.colorbar(ScalarMappable(Normalize(0.0, zmax), cmap), ax=ax, shrink=0.6,
                          pad=0.08)
        cb.set_label(r"$\sqrt{e}$  (e in " + ERROR_UNITS[1:-1] + ")")
        ax.set_xlabel(D1_LABEL, labelpad=8)
        ax.set_ylabel(D2_LABEL, labelpad=8)
        ax.set_zlabel(r"$\sqrt{e}$", labelpad=6)
        ax.set_xlim(g.dtheta1[0], g.dtheta1[-1])
        ax.set_ylim(g.dtheta2[0], g.dtheta2[-1])
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


def whole_cell_surface(X: np.ndarray, Y: np.ndarray, Z: np.ndarray, *, cmap: str,
                       vmax: float) -> Poly3DCollection:
    """The cells of the surface ``Z(X, Y)`` whose four corners are finite, as quadrilaterals
    coloured by their mean height (``cmap`` over ``0..vmax``) and shaded by a light from the
    upper left, as ``plot_surface`` shades."""
    corners = [(slice(None, -1), slice(None, -1)), (slice(1, None), slice(None, -1)),
               (slice(1, None), slice(1, None)), (slice(None, -1), slice(1, None))]
    quads = np.stack([np.stack([A[c] for c in corners], axis=-1) for A in (X, Y, Z)], axis=-1)
    quads = quads.reshape(-1, 4, 3)
    quads = quads[np.isfinite(quads).all(axis=(1, 2))]
    z_mean = quads[:, :, 2].mean(axis=1)
    colours = colormaps[cmap](Normalize(0.0, vmax)(z_mean))
    normals = np.cross(quads[:, 2] - quads[:, 0], quads[:, 3] - quads[:, 1])
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    # the sign of a normal is arbitrary: light the side facing up
    normals *= np.sign(normals[:, 2:3] + (normals[:, 2:3] == 0))
    shade = LightSource(azdeg=225, altdeg=19.4712).shade_normals(normals, fraction=1.0)
    colours[:, :3] *= (0.35 + 0.65 * shade)[:, None]
    return Poly3DCollection(quads, facecolors=colours, edgecolors=(0, 0, 0, 0.15),
                            linewidths=0.15)


def jump_points(z: np.ndarray, jump: float) -> np.ndarray:
    """Points of ``z`` that exceed a 4-neighbour by more than ``jump``: the high side of a
    discontinuity."""
    out = np.zeros(z.shape, bool)
    with np.errstate(invalid="ignore"):
        for axis in (0, 1):
            d = np.diff(z, axis=axis)
            lo = [slice(None)] * 2
            hi = [slice(None)] * 2
            lo[axis], hi[axis] = slice(None, -1), slice(1, None)
            out[tuple(hi)] |= d > jump          # the later point is higher
            out[tuple(lo)] |= -d > jump         # the earlier point is higher
    return out


# ----------------------------------------------------------------------------------------------
# Nelder-Mead convergence of a refine step
# ----------------------------------------------------------------------------------------------
def plot_refine_convergence(refine):
    """Best-vertex error per Nelder-Mead iteration of a ``refine`` dataset (log scale), one
    line per start.

    Shows where the search stalls (the tick-quantised error surface stops the simplex above
    zero). Lines have ``gid`` ``iterate_error`` (one start) or ``iterate_error_<i>``.
    """
    starts = _split_starts(refine)
    mins = minima_from([refine])
    with style():
        fig = new_figure(figsize=(7.0, 4.6))
        ax = fig.add_subplot()
        lines = []
        for k, ((label, r), m) in enumerate(zip(starts, mins)):
            err = np.asarray(r["iterate_error"].values, float)
            it = np.asarray(r["iteration"].values if "iteration" in r.coords
                            else np.arange(err.size), float)
            keep = np.isfinite(err) & (err > 0)
            if "iterate_nfev" in r:                     # multi-start padding is -1
                keep &= np.asarray(r["iterate_nfev"].values) >= 0
            start = f"start ({m.start[0]:.3f}, {m.start[1]:.3f}) → " if m.start else ""
            ax.plot(it[keep], err[keep], marker=".",
                    gid="iterate_error" if len(starts) == 1 else f"iterate_error_{k}",
                    label=f"{label}: {start}e = {m.error:.3g} at "
                          f"({m.dtheta1:.4f}, {m.dtheta2:.4f})")
            lines.append(m)
        ax.set_yscale("log")
        ax.set_xlabel("Nelder–Mead iteration")
        ax.set_ylabel(("section" if is_sequence(refine) else "gait")
                      + f" error e of the best vertex  {ERROR_UNITS}")
        ax.legend(loc="upper right", fontsize=8)
        conv = refine["converged"] if "converged" in refine else refine.attrs.get("converged")
        conv = np.atleast_1d(np.asarray(getattr(conv, "values", conv) if conv is not None
                                        else [], dtype=float))
        note = ("" if conv.size == 0 else "converged (xatol, fatol met)" if np.all(conv == 1)
                else "stopped at the iteration limit" if np.all(conv == 0)
                else f"{int(np.sum(conv == 1))} of {conv.size} starts converged")
        fig.suptitle(f"Nelder–Mead refinement {refine.attrs.get('step_name', '')}", x=0.02,
                     ha="left", fontweight="bold")
        ax.set_title((note + "\n" if note else "") + run_label(refine), fontsize=8.5,
                     fontweight="normal", loc="left")
    return fig


def _refines(path: Path, folder: Folder) -> list[Path]:
    return list(folder.files.get("refine", []))


def _has_swap_times(path: Path, folder: Folder) -> bool:
    return "t_switch" in folder.loaded(path)


def _has_iterations(path: Path, folder: Folder) -> bool:
    ds = folder.loaded(path)
    return ds.sizes.get("iteration", 0) > 0 and "iterate_error" in ds


#: how the grid and refine steps' figures are drawn
DRAWINGS = {
    ("grid", "surface"): Drawing(lambda d: plot_error_surface(d[0])),
    ("grid", "map"): Drawing(lambda d: plot_error_map(d[0], d[1:]), extra_inputs=_refines),
    ("grid", "swap_time"): Drawing(lambda d: plot_swap_time_map(d[0], d[1:]),
                                   extra_inputs=_refines, applies=_has_swap_times),
    ("refine", "convergence"): Drawing(lambda d: plot_refine_convergence(d[0]),
                                       applies=_has_iterations),
}
