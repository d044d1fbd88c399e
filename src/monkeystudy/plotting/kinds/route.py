"""The route step's figures: a route planned across a wall from an atlas of gaits, and the
route walked many times under noise (docs/route.md; the dataset's layout in
docs/datasets.md, "route").

* :func:`plot_route_wall` - the wall (steel, holes, start, goal) and the planned route, each
  step coloured by its gait;
* :func:`plot_route_walks` - every walked route over the wall, arrived and failed, and where
  the failed ones failed;
* :func:`plot_gait_atlas` - each gait's spectral radius and MFPT against its rise per step;
* :func:`plot_route_outcomes` - how the walks ended, and the time and energy of those that
  arrived;
* the noiseless walk of the plan, animated over the wall
  (:func:`monkeystudy.plotting.gait.write_animation` with the wall as its backdrop).

:data:`DRAWINGS` registers them under ``("route", suffix)``. Artists carry ``gid`` s (in each
docstring) so the tests can read back their data.
"""
from __future__ import annotations

import json
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch, Polygon
from matplotlib.text import Text

from ...analysis.route import mirrored_name
from ...wall import Wall
from ..common import (
    BLACK, BLUE, GREEN, ORANGE, PURPLE, SKY, VERMILLION, YELLOW, count, new_figure,
    plain_log_labels, style,
)
from ..drawing import Drawing, Folder, NothingToDraw
from ..gait import has_trajectory, trajectory, write_animation
from ..labels import run_line, two_titles

#: steel, the holes in it and their outlines
STEEL, STEEL_EDGE, HOLE, HOLE_EDGE = "0.86", "0.55", "white", "0.3"
#: the gaits' colours, in the order of the dataset's ``gait`` coordinate
GAIT_COLOURS = [BLUE, VERMILLION, GREEN, PURPLE, ORANGE, SKY, BLACK, "#999999"]
#: the walks' colours: arrived, failed
ARRIVED, FAILED = GREEN, VERMILLION
#: each failure cause's marker on the walks figure (a cause not listed takes a spare one)
CAUSE_MARKERS = {"off_steel": "X", "no_catch": "v", "fell": "s", "stalled": "D",
                 "no_route": "P", "max_steps": "*"}
SPARE_MARKERS = ["^", "<", ">", "h", "p", "8"]
#: each outcome's bar colour (arrived first; a cause not listed takes a spare colour)
CAUSE_COLOURS = {"off_steel": VERMILLION, "no_catch": ORANGE, "fell": PURPLE,
                 "stalled": "#999999", "no_route": SKY, "max_steps": BLUE}
SPARE_COLOURS = [YELLOW, BLACK, "#8c564b", "#7f7f7f"]
#: the walks' lines are drawn this opaque (arrived, failed), so that where many overlap reads
#: darker; the failed, fewer and shorter, more so
WALK_ALPHA = {"walk_arrived": 0.25, "walk_failed": 0.6}
#: the animation's view: the wall and the robot's motion, with this much room [m]
VIEW_PAD = 0.25


def route_wall(ds) -> Wall:
    """The wall of a route dataset (its ``wall`` attribute)."""
    return Wall.from_dict(json.loads(ds.attrs["wall"]))


def gait_names(ds) -> list[str]:
    """The atlas's gait names, in the dataset's order."""
    return [str(g) for g in ds["gait"].values]


def gait_colours(ds) -> dict[str, str]:
    """Each gait's colour, by its place in the atlas (the same on every figure)."""
    return {g: GAIT_COLOURS[k % len(GAIT_COLOURS)] for k, g in enumerate(gait_names(ds))}


def plan_points(ds, wall: Wall) -> np.ndarray:
    """The planned route's magnet positions (steps + 1, 2) [m]: the start, then each catch."""
    catches = np.column_stack([np.asarray(ds["plan_catch_x"].values, float),
                               np.asarray(ds["plan_catch_y"].values, float)])
    return np.vstack([np.asarray(wall.start.position, float)[None, :], catches])


def draw_wall(ax, wall: Wall, *, labels: bool = True) -> list:
    """Draw the wall on ``ax``: each region's steel light grey, its holes white with their
    outline (clipped to the steel: a notch in an edge shows as one), the start (a ringed dot)
    and the goal's disc; with ``labels`` the words "start" and "goal" beside them. Returns
    the legend entries.

    gids: ``steel`` (one per region), ``hole`` (one per hole), ``start``, ``goal``.
    """
    for region in wall.regions:
        plate = Polygon(region.outline, closed=True, facecolor=STEEL, edgecolor=STEEL_EDGE,
                        lw=1.0, zorder=0.5, gid="steel")
        ax.add_patch(plate)
        for hole in region.holes:
            cut = Polygon(hole, closed=True, facecolor=HOLE, edgecolor=HOLE_EDGE, lw=1.0,
                          zorder=0.6, gid="hole")
            ax.add_patch(cut)
            cut.set_clip_path(plate)
    goal = Circle(wall.goal.position, wall.goal.radius, facecolor=GREEN, alpha=0.3,
                  edgecolor=GREEN, lw=1.2, zorder=0.7, gid="goal")
    ax.add_patch(goal)
    ax.plot(*wall.start.position, marker="o", ms=7, mfc=BLACK, mec="#B8860B", mew=2.0,
            ls="none", zorder=8, gid="start")
    if labels:
        ax.annotate("start", wall.start.position, xytext=(0, 7), textcoords="offset points",
                    ha="center", va="bottom", fontsize=8, fontweight="bold", zorder=8)
        gx, gy = wall.goal.position
        ax.annotate("goal", (gx, gy + wall.goal.radius), xytext=(0, 2),
                    textcoords="offset points", ha="center", va="bottom", fontsize=8,
                    fontweight="bold", color="#005a46", zorder=8)
    return [Patch(facecolor=STEEL, edgecolor=STEEL_EDGE, label="steel"),
            Patch(facecolor=HOLE, edgecolor=HOLE_EDGE, label="hole (no steel)"),
            Line2D([], [], marker="o", ms=6, mfc=BLACK, mec="#B8860B", mew=2.0, ls="none",
                   label=f"start (end {wall.start.attached} attached)"),
            Patch(facecolor=GREEN, alpha=0.3, edgecolor=GREEN,
                  label=f"goal (radius {wall.goal.radius:g} m)")]


def _wall_axes(ax, wall: Wall, points=()) -> None:
    """Equal axes in metres holding the wall and ``points`` (n, 2)."""
    x0, y0, x1, y1 = wall.extent
    pts = np.asarray(points, float).reshape(-1, 2)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if pts.size:
        x0, y0 = min(x0, pts[:, 0].min()), min(y0, pts[:, 1].min())
        x1, y1 = max(x1, pts[:, 0].max()), max(y1, pts[:, 1].max())
    pad = 0.03 * max(x1 - x0, y1 - y0)
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x, along the wall  [m]")
    ax.set_ylabel("y, up  [m]")
    ax.grid(False)


def _wall_size(wall: Wall, width: float = 9.0, extra: float = 2.2) -> tuple[float, float]:
    """A figure ``width`` inches wide whose axes show the wall at equal scale, with
    ``extra`` inches for the titles and the legend."""
    x0, y0, x1, y1 = wall.extent
    return width, (width - 1.0) * (y1 - y0) / max(x1 - x0, 1e-9) * 1.06 + extra


def _subtitle(ds) -> str:
    a = ds.attrs
    return (f"cost {a.get('cost')}, risk weight {float(a.get('risk_weight', 0.0)):g}; "
            f"{count(int(a.get('walks', ds.sizes.get('run', 0))), 'walk')} under noise, up to "
            f"{count(int(a.get('max_steps', ds.sizes.get('step', 0))), 'step')}, seed "
            f"{a.get('seed')}; " + run_line(ds, tick=False))


def _plan_title(ds) -> str:
    a = ds.attrs
    if int(a["planned_steps"]) == 0:
        return "No route: no catches on steel lead from the start to the goal"
    return (f"Planned route, {count(int(a['planned_steps']), 'step')}: "
            f"P(arrive) {float(a['planned_p_arrive_survival']):.3f} from the gaits' "
            f"survival curves ({float(a['planned_p_arrive']):.3f} at a constant hazard), "
            f"{float(a['planned_time']):.3g} s, {float(a['planned_energy']):.3g} J")


def plot_route_wall(ds):
    """The wall and the planned route: the start and each planned catch joined, each step in
    its gait's colour (a legend entry per gait the plan uses, in the atlas's order), each
    catch numbered.

    gids: ``steel``, ``hole``, ``start``, ``goal`` (:func:`draw_wall`), ``plan_step_<k>``
    (step k's segment, from 1), ``plan_catches`` (the catch points).
    """
    wall = route_wall(ds)
    pts = plan_points(ds, wall)
    gaits = [str(g) for g in ds["plan_gait"].values]
    colours = gait_colours(ds)
    with style():
        fig = new_figure(figsize=_wall_size(wall))
        body = two_titles(fig, _plan_title(ds), _subtitle(ds))
        ax = body.subplots()
        handles = draw_wall(ax, wall)
        for k, gait in enumerate(gaits, start=1):
            ax.plot(pts[k - 1:k + 1, 0], pts[k - 1:k + 1, 1], "-", color=colours[gait], lw=2.4,
                    solid_capstyle="round", zorder=5, gid=f"plan_step_{k}")
        ax.plot(pts[1:, 0], pts[1:, 1], "o", ms=4, color=BLACK, zorder=6, gid="plan_catches")
        for k, (x, y) in enumerate(pts[1:], start=1):
            ax.annotate(str(k), (x, y), xytext=(0, -9), textcoords="offset points",
                        ha="center", va="top", fontsize=6.5, color="0.2", zorder=6)
        _wall_axes(ax, wall, pts)
        used = [g for g in gait_names(ds) if g in gaits]
        gait_handles = [Line2D([], [], color=colours[g], lw=2.4, label=g) for g in used]
        body.legend(handles=gait_handles + handles, loc="outside lower center",
                    ncols=min(len(gait_handles) + len(handles), 4), frameon=False,
                    fontsize=8)
    return fig


def walk_paths(ds, wall: Wall) -> list[np.ndarray]:
    """Each run's path (n + 1, 2) [m]: the start and its catches (the true magnet positions)
    up to where it ended."""
    cx = np.asarray(ds["catch_x"].transpose("run", "step").values, float)
    cy = np.asarray(ds["catch_y"].transpose("run", "step").values, float)
    walked = np.asarray(ds["steps_walked"].values, int)
    start = np.asarray(wall.start.position, float)[None, :]
    out = []
    for run in range(cx.shape[0]):
        n = walked[run]
        p = np.column_stack([cx[run, :n], cy[run, :n]])
        out.append(np.vstack([start, p[np.all(np.isfinite(p), axis=1)]]))
    return out


def _causes(failure: np.ndarray) -> list[str]:
    """The failure causes of the runs, the most frequent first (ties by name)."""
    names, counts = np.unique([f for f in failure if f], return_counts=True)
    return [str(n) for _, n in sorted(zip(-counts, names))]


def cause_styles(causes) -> dict[str, tuple[str, str]]:
    """Each cause's (marker, colour), the listed ones fixed and the rest from the spares."""
    out, k = {}, 0
    for c in causes:
        if c in CAUSE_MARKERS:
            out[c] = (CAUSE_MARKERS[c], CAUSE_COLOURS[c])
        else:
            out[c] = (SPARE_MARKERS[k % len(SPARE_MARKERS)], SPARE_COLOURS[k % len(SPARE_COLOURS)])
            k += 1
    return out


def plot_route_walks(ds):
    """Every walked route over the wall: each run's path from the start through its catches,
    thin and see-through, the arrived runs green, the failed ones red on top of them (each in
    the order of the runs); the planned route dashed; where each failed run failed, marked by
    its cause; and how many arrived.

    gids: ``walk_arrived`` and ``walk_failed`` (one line per run), ``plan``,
    ``failure_<cause>`` (the failure points), ``arrived_text``; the wall's as in
    :func:`draw_wall`.
    """
    wall = route_wall(ds)
    arrived = np.asarray(ds["arrived"].values, bool)
    failure = np.asarray(ds["failure"].values).astype(str)
    n = arrived.size
    if n == 0:
        raise NothingToDraw("the step walked the route no time (walks: 0)")
    paths = walk_paths(ds, wall)
    plan = plan_points(ds, wall)
    fx = np.asarray(ds["failure_x"].values, float)
    fy = np.asarray(ds["failure_y"].values, float)
    causes = _causes(failure[~arrived])
    styles = cause_styles(causes)
    k = int(arrived.sum())
    with style():
        fig = new_figure(figsize=_wall_size(wall))
        body = two_titles(fig, f"The planned route walked {count(n, 'time')} under noise: "
                          f"{ds.attrs.get('step_name')}", _subtitle(ds))
        ax = body.subplots()
        handles = draw_wall(ax, wall)
        # the arrived runs first, the failed on top (rarer, and the figure is about them)
        for group, colour, gid in ((np.flatnonzero(arrived), ARRIVED, "walk_arrived"),
                                   (np.flatnonzero(~arrived), FAILED, "walk_failed")):
            for run in group:
                p = paths[run]
                ax.plot(p[:, 0], p[:, 1], "-", color=colour, lw=0.8, alpha=WALK_ALPHA[gid],
                        zorder=3, gid=gid)
        ax.plot(plan[:, 0], plan[:, 1], "--", color=BLACK, lw=1.0, zorder=4, gid="plan")
        cause_handles = []
        for cause in causes:
            at = (failure == cause) & ~arrived
            marker, colour = styles[cause]
            label = f"failed: {cause.replace('_', ' ')} ({int(at.sum())})"
            ax.plot(fx[at], fy[at], marker=marker, ms=6, ls="none", mfc=colour, mec=BLACK,
                    mew=0.6, zorder=7, gid=f"failure_{cause}")
            cause_handles.append(Line2D([], [], marker=marker, ms=6, ls="none", mfc=colour,
                                        mec=BLACK, mew=0.6, label=label))
        ax.text(0.01, 0.99, f"arrived {k} of {n} ({100.0 * k / n:.3g} %)",
                transform=ax.transAxes, ha="left", va="top", fontsize=10,
                fontweight="bold", zorder=9, gid="arrived_text",
                bbox=dict(boxstyle="round,pad=0.3", facecolor="white", alpha=0.85, lw=0))
        _wall_axes(ax, wall, np.vstack([np.vstack(paths), np.column_stack([fx, fy])]))
        lines = [Line2D([], [], color=ARRIVED, lw=1.6, label=f"arrived ({k})"),
                 Line2D([], [], color=FAILED, lw=1.6, label=f"failed ({n - k})"),
                 Line2D([], [], color=BLACK, lw=1.0, ls="--", label="planned route")]
        every = lines + cause_handles + handles
        body.legend(handles=every, loc="outside lower center", ncols=4, frameon=False,
                    fontsize=8)
    return fig


def _groups(x: np.ndarray, y: np.ndarray, c: np.ndarray, names: list[str]):
    """The gaits drawn at one point (a gait and its mirror image): ``(indices, joined
    names)`` per point with a finite ``y``, in the atlas's order."""
    out: dict[tuple, list[int]] = {}
    for k in np.flatnonzero(np.isfinite(y)):
        key = (round(float(x[k]), 9), round(float(y[k]), 12), round(float(c[k]), 9))
        out.setdefault(key, []).append(int(k))

    def joined(idx):
        # a gait and its mirror image: one name, walked both ways
        a, b = (names[k] for k in idx) if len(idx) == 2 else (None, None)
        if a is not None and mirrored_name(a) == b:
            return f"{min(a, b, key=len)} (both ways)"
        return ", ".join(names[k] for k in idx)

    return [(idx, joined(idx)) for idx in out.values()]


def plot_gait_atlas(ds):
    """Each gait of the atlas against its rise per step: its spectral radius (a line at 1:
    unstable above) and its mean first-passage time to failure under the survival noise
    [steps, log] with the 95 % interval; a gait no run of which failed as a lower bound (an
    upward double arrow). Colour: the step's length |dx|. A gait and its mirror image share
    a point and its label.

    gids: ``rho`` (the radii), ``rho_one`` (the line at 1), ``mfpt`` (estimates, one
    errorbar per point), ``mfpt_bound`` (lower bounds), ``label_rho``, ``label_mfpt``
    (the names).
    """
    names = gait_names(ds)
    dy = np.asarray(ds["gait_dy"].values, float)
    length = np.abs(np.asarray(ds["gait_dx"].values, float))
    rho = np.asarray(ds["gait_spectral_radius"].values, float)
    mfpt = np.asarray(ds["gait_mfpt"].values, float)
    low = np.asarray(ds["gait_mfpt_low"].values, float)
    high = np.asarray(ds["gait_mfpt_high"].values, float)
    censored = np.asarray(ds["gait_mfpt_censored"].values, bool)
    runs = np.asarray(ds["gait_survival_runs"].values, int)
    failed = np.asarray(ds["gait_survival_failed"].values, int)
    if not names:
        raise NothingToDraw("the atlas holds no gait")
    norm = matplotlib.colors.Normalize(vmin=float(length.min()) * 0.9,
                                       vmax=float(length.max()) * 1.1 or 1.0)
    cmap = matplotlib.colormaps["viridis"]
    unmeasured = [n for n, r in zip(names, rho) if not np.isfinite(r)]
    with style():
        fig = new_figure(figsize=(7.4, 7.4))
        body = two_titles(fig, f"The atlas's gaits: {ds.attrs.get('step_name')}",
                          "each gait's spectral radius and mean first-passage time under the "
                          "survival noise, against the rise of one step; "
                          + run_line(ds, tick=False))
        ax_rho, ax_mfpt = body.subplots(2, 1, sharex=True)
        rho_labels, mfpt_labels = [], []
        for idx, label in _groups(dy, rho, length, names):
            k = idx[0]
            ax_rho.scatter([dy[k]], [rho[k]], s=70, color=cmap(norm(length[k])),
                           edgecolor=BLACK, lw=0.6, zorder=4, gid="rho")
            rho_labels.append(ax_rho.annotate(
                label, (dy[k], rho[k]), xytext=(0, 9), textcoords="offset points",
                ha="center", va="bottom", fontsize=8, gid="label_rho", arrowprops=LEADER))
        ax_rho.axhline(1.0, color=VERMILLION, lw=1.2, ls="--", gid="rho_one",
                       label="ρ = 1: a map with ρ above it is unstable")
        top = np.nanmax(np.append(rho, 1.0))
        ax_rho.set_ylim(0.0, 1.15 * top)
        ax_rho.set_ylabel("spectral radius ρ of the step's map")
        ax_rho.legend(loc="upper left", fontsize=8)
        if unmeasured:
            ax_rho.text(0.99, 0.03, "ρ not measured: " + ", ".join(unmeasured),
                        transform=ax_rho.transAxes, ha="right", va="bottom", fontsize=8,
                        color="0.3", gid="rho_unmeasured")
        shown = np.where(censored, mfpt, np.nan)
        for idx, label in _groups(dy, np.where(np.isfinite(mfpt), mfpt, np.nan), length,
                                  names):
            k = idx[0]
            colour = cmap(norm(length[k]))
            note = f"{label}\n{mfpt[k]:.3g}, {failed[k]} of {count(runs[k], 'run')} failed"
            if censored[k]:
                ax_mfpt.plot([dy[k]], [mfpt[k]], ls="none", marker=r"$\Uparrow$", ms=16,
                             color=colour, mec=BLACK, mew=0.3, zorder=4, gid="mfpt_bound")
                # censored: no failure late in the runs (early ones, of weak builds, may be);
                # a bound with no failure at all is the legend's, said once
                note = (f"{label}\n≥ {mfpt[k]:.3g}, {failed[k]} of {count(runs[k], 'run')} "
                        "failed early" if failed[k] else f"{label}\n≥ {mfpt[k]:.3g}")
            else:
                lo = mfpt[k] - low[k] if np.isfinite(low[k]) else 0.0
                hi = high[k] - mfpt[k] if np.isfinite(high[k]) else 0.0
                ax_mfpt.errorbar([dy[k]], [mfpt[k]], yerr=[[lo], [hi]], marker="o", ms=8,
                                 color=colour, mec=BLACK, mew=0.6, capsize=3, lw=1.4,
                                 ls="none", zorder=4, gid="mfpt")
            mfpt_labels.append(ax_mfpt.annotate(
                note, (dy[k], mfpt[k]), xytext=(0, 14), textcoords="offset points",
                ha="center", va="bottom", fontsize=7.5, gid="label_mfpt", arrowprops=LEADER))
        ax_mfpt.set_yscale("log")
        plain_log_labels(ax_mfpt.yaxis)
        # an interval unbounded above (high inf: its bar is drawn without an upper part)
        # sets no limit
        ends = np.concatenate([low, high, mfpt])
        ends = ends[np.isfinite(ends)]
        lo_y = ends.min() if np.isfinite(mfpt).any() else 1.0
        hi_y = ends.max() if np.isfinite(mfpt).any() else 10.0
        ax_mfpt.set_ylim(max(lo_y, 1e-3) / 3.0, hi_y * 30.0)    # room for the labels above
        ax_mfpt.set_ylabel("mean steps before failure")
        ax_mfpt.set_xlabel("rise per step dy  [m]")
        handles = [Line2D([], [], ls="none", marker="o", color="0.5", mec=BLACK,
                          label="MFPT, 95 % interval")]
        if np.isfinite(shown).any():
            handles.append(Line2D([], [], ls="none", marker=r"$\Uparrow$", ms=12,
                                  color="0.5", label="lower bound: no run failed late (of "
                                  f"{count(int(runs.max()), 'run')} per gait)"))
        ax_mfpt.legend(handles=handles, loc="lower left", fontsize=8)
        span = max(float(np.ptp(dy)), 0.1)
        ax_mfpt.set_xlim(float(dy.min()) - 0.3 * span, float(dy.max()) + 0.3 * span)
        bar = body.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap),
                            ax=[ax_rho, ax_mfpt], shrink=0.6)
        bar.set_label("step length |dx|  [m]")
        unstack_labels(fig, ax_rho, rho_labels)
        unstack_labels(fig, ax_mfpt, mfpt_labels)
    return fig


#: the line from a label raised above its neighbours' to its point
LEADER = {"arrowstyle": "-", "lw": 0.5, "color": "0.5", "shrinkA": 0.0, "shrinkB": 4.0}


def text_extent(ann, renderer):
    """An annotation's text's box in display units (its leader line left out)."""
    return Text.get_window_extent(ann, renderer)


def unstack_labels(fig, ax, labels: list, gap: float = 2.0, rounds: int = 3) -> None:
    """Raise the labels of ``ax`` (annotations in offset points above their points, drawn
    with :data:`LEADER`) that overlap one placed before them (from the left) until none
    overlaps, ``gap`` points apart, and raise the axis' top to hold them (then again from
    their first places, the points having moved: ``rounds`` times at most); a label left at
    its place shows no leader line. The figure is drawn to measure them."""
    if not labels:
        return
    renderer = fig.canvas.get_renderer()
    points = fig.dpi / 72.0                      # display pixels per point
    first = {id(a): a.xyann for a in labels}
    for _ in range(rounds):
        for ann in labels:
            ann.xyann = first[id(ann)]
        fig.canvas.draw()
        placed = []
        for ann in sorted(labels, key=lambda a: a.xy[0]):
            box = text_extent(ann, renderer)
            rise = 0.0
            for other in sorted(placed, key=lambda b: b.y0):
                moved = box.translated(0.0, rise)
                if moved.x1 > other.x0 and moved.x0 < other.x1 and \
                        moved.y1 > other.y0 - gap * points and \
                        moved.y0 < other.y1 + gap * points:
                    rise = other.y1 + gap * points - box.y0
            x, y = ann.xyann
            ann.xyann = (x, y + rise / points)
            ann.arrow_patch.set_visible(rise > 0.0)
            placed.append(box.translated(0.0, rise))
        fig.canvas.draw()
        top = max(text_extent(a, renderer).y1 for a in labels)
        box = ax.get_window_extent(renderer)
        if top <= box.y1:
            return
        lo, hi = ax.get_ylim()
        log = ax.get_yscale() == "log"
        a, b = (np.log10(lo), np.log10(hi)) if log else (lo, hi)
        # the axis grows by the labels' overshoot, and a little more
        grown = a + (b - a) * (top - box.y0 + 4 * gap * points) / max(box.height, 1.0)
        ax.set_ylim(lo, 10.0 ** grown if log else grown)


def plot_route_outcomes(ds):
    """How the walks ended: the number of runs that arrived and that failed by each cause
    (bars, the most frequent cause first), and the walk time and motor energy of the runs
    that arrived (histograms) with the plan's expected values.

    gids: ``outcome_arrived``, ``outcome_<cause>`` (the bars), ``walk_time``,
    ``walk_energy`` (the histograms), ``planned_time``, ``planned_energy`` (the lines).
    """
    arrived = np.asarray(ds["arrived"].values, bool)
    failure = np.asarray(ds["failure"].values).astype(str)
    n = arrived.size
    if n == 0:
        raise NothingToDraw("the step walked the route no time (walks: 0)")
    causes = _causes(failure[~arrived])
    styles = cause_styles(causes)
    with style():
        fig = new_figure(figsize=(10.0, 4.4))
        body = two_titles(fig, f"How the {count(n, 'walk')} ended: "
                          f"{ds.attrs.get('step_name')}", _subtitle(ds))
        ax_bar, ax_t, ax_e = body.subplots(1, 3, width_ratios=[1.3, 1, 1])
        labels = ["arrived"] + [c.replace("_", " ") for c in causes]
        heights = [int(arrived.sum())] + [int(np.sum((failure == c) & ~arrived))
                                          for c in causes]
        colours = [ARRIVED] + [styles[c][1] for c in causes]
        gids = ["outcome_arrived"] + [f"outcome_{c}" for c in causes]
        for x, (h, colour, gid) in enumerate(zip(heights, colours, gids)):
            ax_bar.bar([x], [h], color=colour, gid=gid, width=0.7)
            ax_bar.annotate(str(h), (x, h), xytext=(0, 2), textcoords="offset points",
                            ha="center", va="bottom", fontsize=8)
        ax_bar.set_xticks(np.arange(len(labels)), labels, rotation=30, ha="right",
                          fontsize=8)
        ax_bar.set_ylabel("runs")
        ax_bar.set_ylim(0, max(heights) * 1.12 + 1)
        ax_bar.grid(False, axis="x")
        ax_bar.set_title("how each walk ended", fontsize=9)
        for ax, var, planned, unit, gid, what in (
                (ax_t, "walk_time", "planned_time", "s", "walk_time", "walk time"),
                (ax_e, "walk_energy", "planned_energy", "J", "walk_energy", "motor energy")):
            values = np.asarray(ds[var].values, float)[arrived]
            values = values[np.isfinite(values)]
            ax.set_title(f"{what} of the arrived runs", fontsize=9)
            ax.set_xlabel(f"{what}  [{unit}]")
            if values.size:
                ax.hist(values, bins=min(30, max(5, values.size // 5)), color=ARRIVED,
                        alpha=0.8, gid=gid)
            else:
                ax.text(0.5, 0.5, "no run arrived", transform=ax.transAxes, ha="center",
                        va="center", color="0.4")
            if planned in ds.attrs:
                ax.axvline(float(ds.attrs[planned]), color=BLACK, ls="--", lw=1.2,
                           gid=f"planned_{planned.split('_')[1]}",
                           label=f"planned {float(ds.attrs[planned]):.3g} {unit}")
                ax.legend(loc="upper right", fontsize=8)
            ax.set_ylabel("arrived runs")
    return fig


def replay_recorded(path: Path, folder: Folder) -> bool:
    """The step recorded the noiseless walk's trajectory (the animation needs samples)."""
    ds = folder.loaded(path)
    return has_trajectory(ds) and ds.sizes.get("sample", 0) > 0


def wall_backdrop(wall: Wall):
    """A backdrop for :func:`~monkeystudy.plotting.gait.write_animation`: the wall without
    its words (the legend names them) and without a grid over the steel."""
    def draw(ax) -> list:
        ax.grid(False)
        return draw_wall(ax, wall, labels=False)
    return draw


def animation_view(ds, wall: Wall) -> tuple[tuple[float, float], tuple[float, float]]:
    """The animation's fixed view ``((x0, x1), (y0, y1))`` [m]: the wall and every point
    of the robot's walk, :data:`VIEW_PAD` round them."""
    traj = trajectory(ds)
    pts = np.concatenate([traj.A, traj.joint, traj.B])
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    x0, y0, x1, y1 = wall.extent
    x0, y0 = min(x0, pts[:, 0].min()), min(y0, pts[:, 1].min())
    x1, y1 = max(x1, pts[:, 0].max()), max(y1, pts[:, 1].max())
    return (x0 - VIEW_PAD, x1 + VIEW_PAD), (y0 - VIEW_PAD, y1 + VIEW_PAD)


def write_route_animation(ds, base: Path, prov: dict, *, fps: float = 15.0,
                          max_frames: int = 300, fmt: str | None = None,
                          progress=None) -> list[Path]:
    """The noiseless walk of the planned route animated over the whole wall (its steel,
    holes, start and goal behind the robot)."""
    wall = route_wall(ds)
    title = (f"The planned route walked without noise: "
             f"{count(int(ds.attrs.get('planned_steps', ds.sizes.get('plan_step', 0))), 'step')}"
             f", {float(ds.attrs.get('planned_time', float('nan'))):.3g} s planned")
    return write_animation(ds, base, prov, fps=fps, max_frames=max_frames, fmt=fmt,
                           progress=progress, title=title, view=animation_view(ds, wall),
                           backdrop=wall_backdrop(wall))


def animation(d, base: Path, prov: dict, *, fps: float, max_frames: int,
              progress=None) -> list[Path]:
    """The noiseless walk's animation, written beside the figures."""
    return write_route_animation(d[0], base, prov, fps=fps, max_frames=max_frames,
                                 progress=progress)


#: how the route step's figures are drawn
DRAWINGS = {
    ("route", "wall"): Drawing(
        title="the wall and the planned route",
        caption="The wall (steel grey, holes white), the start and the goal, and the route "
                "the planner chose: each step a line from one catch to the next in the colour "
                "of the gait that makes it, the catches numbered. The title gives the plan's "
                "chance of arriving and its time and energy.",
        draw=lambda d: plot_route_wall(d[0])),
    ("route", "walks"): Drawing(
        title="the route walked under noise",
        caption="Every walk of the route under noise, from the start through the catches the "
                "robot really made: green the walks that reached the goal, red those that "
                "failed, each failure marked where it happened and by why; the plan dashed. "
                "Walks that stray from the plan were replanned from where the robot thought "
                "it was.",
        draw=lambda d: plot_route_walks(d[0])),
    ("route", "atlas"): Drawing(
        title="the gaits of the atlas",
        caption="Each gait the planner could use, against how far one step rises: its "
                "spectral radius (below 1 the gait's own map returns to its cycle) and how "
                "many steps it lasts on average under the survival noise, with the 95 % "
                "interval; an arrow is a lower bound (no run failed late). The colour is the "
                "step's length.",
        draw=lambda d: plot_gait_atlas(d[0])),
    ("route", "outcomes"): Drawing(
        title="how the walks ended",
        caption="How many walks arrived and how many failed for each reason, and how long "
                "the arrived walks took and how much motor energy they spent, beside the "
                "plan's expected time and energy.",
        draw=lambda d: plot_route_outcomes(d[0])),
    ("route", "animation"): Drawing(
        title="animation",
        caption="The planned route walked without noise, as a video over the whole wall: the "
                "links coloured by what the controller does, the magnet that holds, and where "
                "each catch was made.",
        draw=animation,
        applies=replay_recorded, animation=True, cost=8.0),
}
