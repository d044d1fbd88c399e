"""Figures of the route step (monkeystudy.plotting.kinds.route) on a synthetic dataset of the
step's layout (route_dataset.py): a 10 m x 3 m plate with a window, a planned route of about
a dozen steps and 200 walks of it, some failing by each cause."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from matplotlib.collections import LineCollection
from matplotlib.colors import to_hex
from matplotlib.legend import Legend
from matplotlib.lines import Line2D
from PIL import Image

from monkeystudy.plotting.drawing import Folder
from monkeystudy.plotting.kinds.route import (
    DRAWINGS, gait_colours, plan_points, plot_gait_atlas, plot_route_outcomes, plot_route_walks,
    plot_route_wall, replay_recorded, route_wall, walk_paths, write_route_animation,
)

from route_dataset import route_dataset


def gid(fig, name: str) -> list:
    return [a for a in fig.findobj() if a.get_gid() == name]


def legend_texts(fig) -> list[str]:
    """The texts of every legend of the figure and its subfigures."""
    return [t.get_text() for leg in fig.findobj(Legend) for t in leg.get_texts()]


@pytest.fixture(scope="module")
def route_file(tmp_path_factory) -> Path:
    """The dataset written to netCDF as the step writes it."""
    path = tmp_path_factory.mktemp("route") / "route.nc"
    route_dataset().to_netcdf(path)
    return path


@pytest.fixture(scope="module")
def ds(route_file) -> xr.Dataset:
    with xr.open_dataset(route_file) as d:
        return d.load()


def test_the_dataset_is_the_route_layout(ds):
    """The synthetic walks have what the figures are tested on: a plan of about a dozen
    steps, 200 walks, failures of several causes, censored and estimated MFPTs."""
    assert 10 <= ds.sizes["plan_step"] <= 16
    assert ds.sizes["run"] == int(ds.attrs["walks"]) == 200
    causes = set(np.asarray(ds["failure"].values).astype(str)) - {""}
    assert {"off_steel", "no_route", "max_steps", "fell", "no_catch", "stalled"} <= causes
    assert ds["gait_mfpt_censored"].values.any() and not ds["gait_mfpt_censored"].values.all()
    assert int(ds["arrived"].sum()) == int(ds.attrs["arrived_runs"])


def test_the_route_kind_draws_its_figures():
    assert set(DRAWINGS) == {("route", s) for s in
                             ("wall", "walks", "atlas", "outcomes", "animation")}
    assert DRAWINGS[("route", "animation")].animation


def test_the_wall_figure_draws_the_wall_and_each_planned_step_in_its_gait(ds):
    wall = route_wall(ds)
    fig = plot_route_wall(ds)
    assert len(gid(fig, "steel")) == len(wall.regions) == 1
    holes = gid(fig, "hole")
    assert len(holes) == 1
    np.testing.assert_allclose(holes[0].get_xy()[:4], wall.regions[0].holes[0])
    goal = gid(fig, "goal")[0]
    assert goal.center == wall.goal.position and goal.radius == wall.goal.radius
    pts = plan_points(ds, wall)
    gaits = [str(g) for g in ds["plan_gait"].values]
    colours = gait_colours(ds)
    for k, gait in enumerate(gaits, start=1):
        (line,) = gid(fig, f"plan_step_{k}")
        np.testing.assert_allclose(np.column_stack(line.get_data()), pts[k - 1:k + 1])
        assert to_hex(line.get_color()) == to_hex(colours[gait])
    assert not gid(fig, f"plan_step_{len(gaits) + 1}")
    # the legend names each gait of the plan once, in the atlas's order, and no other gait
    atlas = [str(g) for g in ds["gait"].values]
    names = legend_texts(fig)
    shown = [n for n in names if n in atlas]
    assert shown == [g for g in atlas if g in gaits]
    assert len(set(gaits)) >= 2
    title = fig._suptitle.get_text()
    assert f"{float(ds.attrs['planned_p_arrive']):.3f}" in title
    assert f"{float(ds.attrs['planned_p_arrive_survival']):.3f} from the gaits' survival" in \
        title.replace("\n", " ")
    assert f"{float(ds.attrs['planned_time']):.3g} s" in title
    assert f"{float(ds.attrs['planned_energy']):.3g} J" in title.replace("\n", " ")


def test_the_walks_figure_draws_every_run_once_in_its_outcome_colour(ds):
    fig = plot_route_walks(ds)
    arrived = np.asarray(ds["arrived"].values, bool)
    ok, failed = gid(fig, "walk_arrived"), gid(fig, "walk_failed")
    assert len(ok) == int(arrived.sum()) == int(ds.attrs["arrived_runs"])
    assert len(failed) == int((~arrived).sum())
    assert len(ok) + len(failed) == int(ds.attrs["walks"])
    assert len({to_hex(line.get_color()) for line in ok}) == 1
    assert {to_hex(line.get_color()) for line in ok}.isdisjoint(
        {to_hex(line.get_color()) for line in failed})
    # each line is its run's path, the arrived in the order of the runs, then the failed
    paths = walk_paths(ds, route_wall(ds))
    order = list(np.flatnonzero(arrived)) + list(np.flatnonzero(~arrived))
    lines = ok + failed
    ax = ok[0].axes
    assert [ax.lines.index(line) for line in lines] == sorted(ax.lines.index(line)
                                                               for line in lines)
    for line, run in zip(lines, order):
        np.testing.assert_allclose(np.column_stack(line.get_data()), paths[run])
    # a run's path: the start, then one point per catch it made
    walked = np.asarray(ds["steps_walked"].values, int)
    assert [len(paths[r]) for r in range(len(paths))] == list(walked + 1)
    # every failed run's failure point, under its cause
    failure = np.asarray(ds["failure"].values).astype(str)
    for cause in set(failure[~arrived]):
        (points,) = gid(fig, f"failure_{cause}")
        at = failure == cause
        np.testing.assert_allclose(points.get_xdata(), ds["failure_x"].values[at])
        np.testing.assert_allclose(points.get_ydata(), ds["failure_y"].values[at])
    k, n = int(arrived.sum()), arrived.size
    assert gid(fig, "arrived_text")[0].get_text() == \
        f"arrived {k} of {n} ({100.0 * k / n:.3g} %)"


def test_the_walks_figure_is_the_same_drawn_twice(ds):
    first, second = plot_route_walks(ds), plot_route_walks(ds)
    for name in ("walk_arrived", "walk_failed"):
        a, b = gid(first, name), gid(second, name)
        assert len(a) == len(b)
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x.get_xydata(), y.get_xydata())


def test_the_atlas_draws_censored_mfpts_as_lower_bounds_and_rho_where_measured(ds):
    fig = plot_gait_atlas(ds)
    dy = ds["gait_dy"].values
    mfpt = ds["gait_mfpt"].values
    censored = ds["gait_mfpt_censored"].values
    rho = ds["gait_spectral_radius"].values
    # a gait and its mirror image share a point: one marker per distinct point
    bounds = gid(fig, "mfpt_bound")
    bound_points = {(float(b.get_xdata()[0]), float(b.get_ydata()[0])) for b in bounds}
    assert bound_points == {(float(x), float(y)) for x, y in zip(dy[censored], mfpt[censored])}
    assert all(b.get_marker() == r"$\Uparrow$" for b in bounds)
    estimates = gid(fig, "mfpt")          # each errorbar's point, caps and bar
    est_points = {tuple(np.round(e.get_xydata()[0], 12)) for e in estimates
                  if isinstance(e, Line2D) and e.get_marker() == "o"}
    assert est_points == {(round(float(x), 12), round(float(y), 12))
                          for x, y in zip(dy[~censored], mfpt[~censored])}
    assert not est_points & bound_points
    # the 95 % interval: each estimate's error bar spans mfpt_low to mfpt_high
    bars = [e for e in estimates if isinstance(e, LineCollection)]
    spans = sorted(tuple(np.round(seg[:, 1], 9)) for b in bars for seg in b.get_segments())
    lo, hi = ds["gait_mfpt_low"].values[~censored], ds["gait_mfpt_high"].values[~censored]
    assert spans == sorted({(round(float(a), 9), round(float(b), 9)) for a, b in zip(lo, hi)})
    assert gid(fig, "mfpt_bound")[0].axes.get_yscale() == "log"
    # rho: the measured gaits only, a line at 1, the others named
    drawn = {tuple(np.round(c.get_offsets()[0], 12)) for c in gid(fig, "rho")}
    measured = np.isfinite(rho)
    assert drawn == {(round(float(x), 12), round(float(y), 12))
                     for x, y in zip(dy[measured], rho[measured])}
    assert list(gid(fig, "rho_one")[0].get_ydata()) == [1.0, 1.0]
    unmeasured = [str(g) for g, m in zip(ds["gait"].values, measured) if not m]
    assert gid(fig, "rho_unmeasured")[0].get_text() == "ρ not measured: " + ", ".join(unmeasured)
    # a gait and its mirror image share a point and one label
    labels = {t.get_text() for t in gid(fig, "label_rho")}
    assert "level (both ways)" in labels
    assert not any("(mirrored)" in t for t in labels)


def test_the_outcomes_figure_counts_each_cause_and_the_arrived_runs(ds):
    fig = plot_route_outcomes(ds)
    failure = np.asarray(ds["failure"].values).astype(str)
    arrived = np.asarray(ds["arrived"].values, bool)
    (bar,) = gid(fig, "outcome_arrived")
    assert bar.get_height() == arrived.sum()
    for cause in set(failure[~arrived]):
        (bar,) = gid(fig, f"outcome_{cause}")
        assert bar.get_height() == np.sum(failure == cause)
    total = sum(p.get_height() for p in gid(fig, "walk_time"))
    assert total == arrived.sum()
    assert sum(p.get_height() for p in gid(fig, "walk_energy")) == arrived.sum()
    assert gid(fig, "planned_time")[0].get_xdata()[0] == float(ds.attrs["planned_time"])


def test_the_animation_walks_the_plan_over_the_wall(ds, tmp_path, monkeypatch):
    """The wall's steel, holes and goal are drawn behind the robot, the whole wall in view,
    and the file is a GIF of every frame."""
    from monkeystudy.plotting import gait

    figures, made = [], gait.new_figure

    def keep(**kwargs):
        figures.append(made(**kwargs))
        return figures[-1]

    monkeypatch.setattr(gait, "new_figure", keep)
    seen = []
    paths = write_route_animation(ds, tmp_path / "walk", {"study_sha256": "abc"}, fps=2.0,
                                  max_frames=6, fmt="gif",
                                  progress=lambda done, total: seen.append(total))
    assert paths == [tmp_path / "walk.gif"]
    with Image.open(paths[0]) as im:
        assert im.format == "GIF" and im.n_frames >= 2
    assert seen[-1] == 6 + 2
    ax = figures[0].axes[0]
    kinds = [p.get_gid() for p in ax.patches]
    assert kinds.count("steel") == 1 and kinds.count("hole") == 1 and "goal" in kinds
    x0, y0, x1, y1 = route_wall(ds).extent
    assert ax.get_xlim()[0] < x0 and ax.get_xlim()[1] > x1
    assert ax.get_ylim()[0] < y0 and ax.get_ylim()[1] > y1
    texts = legend_texts(figures[0])
    assert "steel" in texts and "start height" not in texts
    assert "planned route walked without noise" in figures[0]._suptitle.get_text()


def test_the_animation_is_drawn_only_for_a_recorded_walk(ds, tmp_path):
    def folder(path):
        return Folder(path.parent, {}, lambda p: xr.open_dataset(p))

    with_walk = tmp_path / "with.nc"
    ds.to_netcdf(with_walk)
    without = tmp_path / "without.nc"
    ds.drop_dims(["sample", "cycle"]).to_netcdf(without)
    empty = tmp_path / "empty.nc"
    ds.isel(sample=slice(0, 0)).drop_encoding().to_netcdf(empty)
    applies = DRAWINGS[("route", "animation")].applies
    assert applies is replay_recorded
    assert applies(with_walk, folder(with_walk))
    assert not applies(without, folder(without))
    assert not applies(empty, folder(empty))


def test_a_backdrop_leaves_the_stability_animation_as_it_was(ds, tmp_path, monkeypatch):
    """Without a backdrop the animation keeps its start-height line and moving camera."""
    from monkeystudy.plotting import gait

    figures, made = [], gait.new_figure

    def keep(**kwargs):
        figures.append(made(**kwargs))
        return figures[-1]

    monkeypatch.setattr(gait, "new_figure", keep)
    gait.write_animation(ds, tmp_path / "plain", {}, fps=2.0, max_frames=4, fmt="gif")
    texts = legend_texts(figures[0])
    assert "start height" in texts and "steel" not in texts
    assert not figures[0].axes[0].patches
    x0, _, x1, _ = route_wall(ds).extent
    lo, hi = figures[0].axes[0].get_xlim()
    assert hi - lo < x1 - x0                 # the camera's window, not the whole wall


def test_the_wall_attribute_reads_back(ds):
    wall = route_wall(ds)
    assert wall.to_dict() == json.loads(ds.attrs["wall"])


@pytest.mark.parametrize("plot", [plot_route_wall, plot_route_walks, plot_gait_atlas,
                                  plot_route_outcomes])
def test_every_figure_fits_in_its_frame(ds, plot):
    """No layout warning, and every artist (titles, legends, labels) inside the figure."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig = plot(ds)
        fig.canvas.draw()
    drawn = fig.get_tightbbox(fig.canvas.get_renderer())
    width, height = fig.get_size_inches()
    assert drawn.x0 >= -0.02 and drawn.x1 <= width + 0.02, (drawn, width)
    assert drawn.y0 >= -0.02 and drawn.y1 <= height + 0.02, (drawn, height)


def test_a_wall_without_a_route_says_so_in_its_title(ds):
    empty = ds.isel(plan_step=slice(0, 0)).assign_attrs(
        planned_steps=0, planned_p_arrive=float("nan"), planned_p_arrive_low=float("nan"),
        planned_p_arrive_survival=float("nan"),
        planned_time=float("nan"), planned_energy=float("nan"))
    fig = plot_route_wall(empty)
    titles = " ".join(t.get_text() for t in fig.texts)
    assert "No route" in titles and "nan" not in titles
