"""Each figure function draws the dataset's numbers: checked on the artists' data, not pixels."""
from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from matplotlib.collections import PathCollection, QuadMesh
from matplotlib.figure import Figure
from matplotlib.text import Text
from PIL import Image

from monkeystudy import OpenLoop, evaluate_horizontal_gait, simulate
from monkeystudy.kernel import layout as L
from monkeystudy.plotting import (
    gait_point, plot_error_comparison, plot_error_map, plot_error_per_cycle, plot_error_surface,
    plot_filmstrip, plot_kinetic_energy, plot_pivot_height, plot_refine_convergence,
    plot_swap_time_map,
    trajectory, write_animation,
)
from monkeystudy.plotting.drawing import NothingToDraw
from monkeystudy.plotting.maps import cell_edges, grid_arrays


def by_gid(fig: Figure, gid: str):
    found = [a for a in fig.findobj() if a.get_gid() == gid]
    assert found, f"no artist with gid {gid!r}"
    return found[0]


def gids(fig: Figure) -> set[str]:
    return {a.get_gid() for a in fig.findobj() if a.get_gid()}


# --- error map (fig. 4) ---------------------------------------------------------------------
def test_error_map_image_is_the_clipped_error(datasets):
    grid = datasets["error_map"]
    fig = plot_error_map(grid, [datasets["refine_1"], datasets["refine_2"]])
    arr = by_gid(fig, "error").get_array()           # [i_dtheta2, i_dtheta1]
    err = grid["error"].transpose("dtheta1", "dtheta2").values
    st = grid["status"].transpose("dtheta1", "dtheta2").values
    expected = np.minimum(err, 5.0).T
    nogait = (st != 0).T
    assert arr.shape == expected.shape
    np.testing.assert_array_equal(np.ma.getmaskarray(arr), nogait)
    np.testing.assert_array_equal(arr.filled(np.nan)[~nogait], expected[~nogait])
    assert arr.max() == pytest.approx(min(5.0, np.nanmax(err)))
    assert nogait.any() and (~nogait).any(), "test grid should have both regions"


def test_error_map_no_gait_region_is_drawn_as_its_own_category(datasets):
    grid = datasets["error_map"]
    g = grid_arrays(grid)
    fig = plot_error_map(grid)
    X, Y = np.meshgrid(g.dtheta1, g.dtheta2, indexing="ij")
    centres = np.column_stack([X.ravel(), Y.ravel()])
    for key, codes in (("unreachable", [L.ST_UNREACHABLE]), ("no_switch", [L.ST_NO_SWITCH])):
        mask = np.isin(g.status, codes).ravel()
        assert mask.any(), f"test grid has no {key} points"
        patch = by_gid(fig, f"nogait_{key}")
        inside = patch.get_path().contains_points(centres)
        np.testing.assert_array_equal(inside, mask)
        assert patch.get_hatch()                    # hatched: distinct from "large error"
    # the legend names the categories
    texts = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert any("cannot reach" in t for t in texts)
    assert any("never reached" in t for t in texts)


def test_error_map_marks_and_labels_the_minima(datasets):
    refines = [datasets["refine_1"], datasets["refine_2"]]
    fig = plot_error_map(datasets["error_map"], refines)
    for r in refines:
        step = r.attrs["step_name"]
        marker = by_gid(fig, f"minimum_{step}")
        assert marker.get_xdata()[0] == pytest.approx(float(r["dtheta1"]))
        assert marker.get_ydata()[0] == pytest.approx(float(r["dtheta2"]))
        number = by_gid(fig, f"label_{step}").get_text()
        keyed = [t.get_text() for leg in fig.legends for t in leg.get_texts()
                 if t.get_text().startswith(f"{number}: {step}, ")]
        assert len(keyed) == 1
        assert f"e = {float(r['error']):.2g}" in keyed[0]
        assert f"({float(r['dtheta1']):.3f}, {float(r['dtheta2']):.3f})" in keyed[0]
        path = by_gid(fig, f"path_{step}")
        np.testing.assert_allclose(path.get_xdata(), r["iterate_dtheta1"].values)


def test_error_map_accepts_explicit_points(datasets):
    grid = datasets["error_map"].stack(point=("dtheta1", "dtheta2")).reset_index("point")
    fig = plot_error_map(grid)
    ref = plot_error_map(datasets["error_map"])
    np.testing.assert_array_equal(by_gid(fig, "error").get_array().filled(-1),
                                  by_gid(ref, "error").get_array().filled(-1))


def test_cell_edges_centre_the_cells():
    e = cell_edges(np.array([0.0, 1.0, 3.0]))
    np.testing.assert_allclose(e, [-0.5, 0.5, 2.0, 4.0])


# --- surface (fig. 3) -----------------------------------------------------------------------
def drawn_faces(coll) -> list[np.ndarray]:
    """The 3-D faces of a Poly3DCollection, padding vertices of triangles dropped (private
    attributes: mplot3d has no public accessor for the 3-D vertices)."""
    faces = coll._faces
    invalid = np.broadcast_to(getattr(coll, "_invalid_vertices", False), faces.shape[:2])
    return [f[~bad] for f, bad in zip(faces, invalid)]


def drawn_z(coll) -> np.ndarray:
    faces = drawn_faces(coll)
    return np.concatenate([f[:, 2] for f in faces]) if faces else np.zeros(0)


def test_surface_heights_are_sqrt_error_and_floor_is_flat(datasets):
    grid = datasets["error_map"]
    fig = plot_error_surface(grid)
    g = grid_arrays(grid)
    root = np.sqrt(g.error)
    surf = by_gid(fig, "sqrt_error")
    faces = drawn_faces(surf)
    assert faces and all(len(f) in (3, 4) and np.isfinite(f).all() for f in faces)
    zmax = np.nanmax(root)
    for f in faces:
        # every vertex is a grid point with a gait, at sqrt(e) of that point
        i = np.searchsorted(g.dtheta1, f[:, 0])
        j = np.searchsorted(g.dtheta2, f[:, 1])
        np.testing.assert_array_equal(g.dtheta1[i], f[:, 0])
        np.testing.assert_array_equal(g.dtheta2[j], f[:, 1])
        np.testing.assert_allclose(f[:, 2], root[i, j], rtol=0, atol=1e-12)
        # never across a jump of more than a tenth of the range
        assert np.ptp(f[:, 2]) <= 0.1 * zmax + 1e-12
    # every point with a gait is on the surface or a dot
    on_surface = {(x, y) for f in faces for x, y in f[:, :2]}
    dots = [a for a in fig.findobj() if a.get_gid() == "sqrt_error_points"]
    dotted = {tuple(p) for d in dots for p in np.column_stack(d._offsets3d[:2])}
    with_gait = {(g.dtheta1[i], g.dtheta2[j]) for i, j in zip(*np.nonzero(g.ok))}
    assert with_gait <= on_surface | dotted
    assert not (on_surface & dotted)
    for key in ("floor_unreachable", "floor_no_switch"):
        fz = drawn_z(by_gid(fig, key))
        assert fz.size and np.all(fz == 0.0)
    assert "√" in fig.axes[0].get_zlabel() or "sqrt" in fig.axes[0].get_zlabel()


def test_surface_of_grids_too_small_for_cells(datasets):
    """A 1 x n grid and a single point have no cell: their points are drawn as dots (and a
    1 x n grid as a curve); a grid without any gait has nothing to draw."""
    grid = datasets["error_map"]
    g = grid_arrays(grid)
    col = int(np.argmax(g.ok.sum(axis=1)))               # the column with most gaits
    row = grid.isel(dtheta1=[col])
    fig = plot_error_surface(row)
    dots = by_gid(fig, "sqrt_error_points")
    z = np.asarray(dots._offsets3d[2], float)
    np.testing.assert_allclose(np.sort(z), np.sort(np.sqrt(g.error[col][g.ok[col]])))
    assert by_gid(fig, "sqrt_error_line")
    i, j = np.argwhere(g.ok)[0]
    one = grid.isel(dtheta1=[i], dtheta2=[j])
    assert by_gid(plot_error_surface(one), "sqrt_error_points")
    none = grid.copy()
    none["status"] = none["status"].where(none["status"] != 0, 2)     # every gait: no switch
    with pytest.raises(NothingToDraw, match="no point of the grid has a gait"):
        plot_error_surface(none)


# --- per-cycle figures (figs. 5-8) ----------------------------------------------------------
def test_error_per_cycle_is_the_dataset_on_a_log_axis(datasets):
    s = datasets["stability_1"]
    fig = plot_error_per_cycle(s, gait=(0.9, 10.9))
    line = by_gid(fig, "error")
    np.testing.assert_array_equal(line.get_xdata(), s["cycle"].values)
    np.testing.assert_array_equal(np.asarray(line.get_ydata()), s["error"].values)
    assert line.axes.get_yscale() == "log"
    assert "rad² + rad² s⁻²" in line.axes.get_ylabel() and "cycle" in line.axes.get_xlabel()


def labelled_ticks(axis) -> list[float]:
    """The values of the ticks of ``axis`` (drawn) with a label, within its view."""
    lo, hi = sorted(axis.get_view_interval())
    ticks = axis.get_major_ticks() + axis.get_minor_ticks()
    return sorted(t.get_loc() for t in ticks
                  if t.label1.get_text() and lo * (1 - 1e-9) <= t.get_loc() <= hi * (1 + 1e-9))


def test_a_log_axis_within_a_decade_has_labelled_ticks_around_its_values(datasets):
    """Errors from 1.1e-4 to 8e-4 (smoke's minima_cycles) had no labelled tick
    below 2e-4 and none above 6e-4. A log axis shorter than a decade ends on labelled ticks
    and labels every minor one: the lowest and highest values lie between labelled ticks."""
    s = datasets["stability_1"].copy()
    n = s.sizes["cycle"]
    s["error"] = ("cycle", np.geomspace(1.12e-4, 7.95e-4, n))
    fig = plot_error_per_cycle(s)
    fig.canvas.draw()
    axis = by_gid(fig, "error").axes.yaxis
    labelled = labelled_ticks(axis)
    assert len(labelled) >= 4, labelled
    assert labelled[0] <= 1.12e-4 and labelled[-1] >= 7.95e-4, labelled


def test_error_comparison_draws_every_run(datasets):
    ss = [datasets["stability_1"], datasets["stability_2"]]
    fig = plot_error_comparison(ss)
    for s in ss:
        line = by_gid(fig, f"error_{s.attrs['step_name']}")
        np.testing.assert_array_equal(np.asarray(line.get_ydata()), s["error"].values)


def test_kinetic_energy_per_cycle(datasets):
    s = datasets["stability_1"]
    g = gait_point(s, [datasets["refine_1"], datasets["refine_2"]])
    assert g == pytest.approx((float(datasets["refine_1"]["dtheta1"]),
                               float(datasets["refine_1"]["dtheta2"])))
    fig = plot_kinetic_energy(s, gait=g)
    line = by_gid(fig, "kinetic_energy")
    np.testing.assert_array_equal(line.get_ydata(), s["kinetic_energy"].values)
    assert "[J]" in line.axes.get_ylabel()
    # the first crossing's kinetic energy is close to the repeated gait's start value
    k0 = by_gid(fig, "ke_start").get_ydata()[0]
    assert s["kinetic_energy"].values[0] == pytest.approx(k0, rel=0.02)


def test_pivot_height_with_link_length_for_scale(datasets):
    s = datasets["stability_1"]
    fig = plot_pivot_height(s)
    line = by_gid(fig, "pivot_height")
    np.testing.assert_array_equal(line.get_ydata(), s["pivot_height"].values)
    assert "[m]" in line.axes.get_ylabel()
    assert by_gid(fig, "start_height").get_ydata()[0] == 0.0
    assert by_gid(fig, "link_length").get_ydata()[0] == pytest.approx(-0.61)
    np.testing.assert_array_equal(by_gid(fig, "x_advance").get_ydata(), s["x_advance"].values)


def test_refine_convergence(datasets):
    r = datasets["refine_1"]
    fig = plot_refine_convergence(r)
    line = by_gid(fig, "iterate_error")
    np.testing.assert_array_equal(line.get_ydata(), r["iterate_error"].values)


# --- the robot: filmstrip and animation -------------------------------------------------------
def test_filmstrip_poses_are_dataset_samples_and_include_the_swap(datasets):
    s = datasets["stability_1"]
    fig = plot_filmstrip(s)
    traj = trajectory(s)
    rows = np.concatenate([traj.A, traj.joint, traj.B], axis=1)    # (n, 6)
    poses = [a for a in fig.findobj() if a.get_gid() == "pose"]
    assert len(poses) >= 8
    times = []
    for p in poses:
        xs, ys = p.get_xdata(), p.get_ydata()
        row = np.array([xs[0], ys[0], xs[1], ys[1], xs[2], ys[2]])
        hit = np.flatnonzero(np.all(np.isclose(rows, row, atol=1e-12), axis=1))
        assert hit.size, "a drawn pose is not a sample of the dataset"
        times.append(traj.t[hit[0]])
    t_swap = traj.t[traj.swaps()[0]]
    assert any(abs(t - t_swap) < 1e-12 for t in times), "the swap frame is missing"
    assert max(times) <= float(s["t_cross"][0]) + 1e-9      # one gait cycle
    colours = {tuple(p.get_color()) if not isinstance(p.get_color(), str) else p.get_color()
               for p in poses}
    assert len(colours) >= 3                                # A, motor on, B stages


def test_attached_end_inferred_from_the_trajectory_matches_the_simulator():
    g = evaluate_horizontal_gait(0.902, 10.935, tick=0.001)
    ds = simulate(OpenLoop(g.t_switch, g.t_motor, 0.6354, tick=0.001),
                  dtheta1=0.902, dtheta2=10.935, cycles=3, sample_dt=0.01)
    truth = np.where(ds["attached_end"].values != 0, "B", "A")
    inferred = trajectory(ds.drop_vars("attached_end")).attached
    assert np.mean(inferred == truth) > 0.995
    # every swap is found at the right sample
    traj = trajectory(ds)
    np.testing.assert_array_equal(trajectory(ds.drop_vars("attached_end")).swaps(), traj.swaps())
    assert len(traj.swaps()) == 3


def test_animation_gif_fallback_is_the_run(datasets, tmp_path):
    s = datasets["stability_1"]
    paths = write_animation(s, tmp_path / "anim", {"study_sha256": "abc123"}, max_frames=6,
                            fps=2, fmt="gif")
    assert paths == [tmp_path / "anim.gif"]
    with Image.open(paths[0]) as im:
        assert im.format == "GIF" and im.n_frames >= 6  # Pillow merges identical frames
        assert im.size[0] >= 960                        # readable: 960 x 600 by default
        total = 0
        for k in range(im.n_frames):
            im.seek(k)
            total += im.info["duration"]
        assert total == (6 + 2) * 500                  # 6 frames + the end held 1 s, at 2 fps
        assert b"study_sha256=abc123" in im.info.get("comment", b"")


def test_animation_is_an_mp4_a_person_can_watch(datasets, tmp_path):
    """With ffmpeg (the imageio-ffmpeg wheel's) the animation is an MP4 at least 960 px wide,
    one frame per sample plus the end held for a second."""
    import subprocess

    from monkeystudy.plotting.gait import animation_format, ffmpeg_path
    assert animation_format() == "mp4", "imageio-ffmpeg is a dependency: ffmpeg must be found"
    s = datasets["stability_1"]
    paths = write_animation(s, tmp_path / "anim", {"study_sha256": "abc123"}, max_frames=6,
                            fps=2)
    assert paths == [tmp_path / "anim.mp4"]
    probe = subprocess.run([ffmpeg_path(), "-i", str(paths[0])], capture_output=True,
                           text=True).stderr
    w, h = (int(v) for v in re.search(r"Video: .*?, (\d+)x(\d+)", probe).groups())
    assert w >= 960 and (w, h) == (960, 600), probe
    assert re.search(r"Duration: 00:00:0(3\.9|4\.0)", probe), probe   # (6 + 2) frames at 2 fps
    assert "study_sha256=abc123" in probe


def test_the_animation_camera_keeps_the_whole_robot_in_view(datasets):
    """Issue 32: the last (falling) frames moved the view so that only a stub of a link was
    left in it. The camera holds every point of the robot in every frame of a run."""
    from monkeystudy.plotting.gait import Camera, animation_frames

    s = datasets["stability_1"]
    traj = trajectory(s)
    frames, _ = animation_frames(traj, fps=15.0, max_frames=240)
    reach = 1.22
    cam = Camera(3.5, 1.6, margin=0.06)
    moves = 0
    for i in frames:
        pts = np.array([traj.A[i], traj.joint[i], traj.B[i]])
        moves += cam.follow(pts.min(axis=0), pts.max(axis=0))
        assert np.all(pts >= cam.lo) and np.all(pts <= cam.lo + cam.size), (i, cam.lo)
    assert moves < len(frames) / 4          # a still view most of the time: frames blit
    assert reach < cam.size[1]


@given(st.lists(st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.floats(0.0, 1.0),
                          st.floats(0.0, 1.0)), min_size=1, max_size=40),
       st.sampled_from([-1.0, 1.0]))
def test_camera_holds_any_box_that_fits(boxes, heading):
    """Whatever the robot does, a box that fits the view (with its margins) is in it."""
    from monkeystudy.plotting.gait import Camera

    cam = Camera(3.0, 2.0, margin=0.1, heading=heading)
    for x, y, w, h in boxes:
        lo, hi = np.array([x, y]), np.array([x + 2.6 * w, y + 1.6 * h])
        cam.follow(lo, hi)
        assert np.all(cam.lo + cam.margin <= lo + 1e-9)
        assert np.all(hi <= cam.lo + cam.size - cam.margin + 1e-9)


def test_animation_reports_every_frame(datasets, tmp_path):
    s = datasets["stability_1"]
    seen = []
    write_animation(s, tmp_path / "anim", {}, max_frames=6, fps=2,
                    progress=lambda done, total: seen.append((done, total)))
    assert seen == [(k, 8) for k in range(1, 9)]         # 6 frames + the end held 1 s


def test_a_point_list_is_titled_and_drawn_as_its_points(datasets):
    """An explicit point list of 3 points at 3 values of each rate was titled "over a 3×3
    grid of initial rates", and drawn as a mesh of cells, 6 of its 9 blank (five listed
    points: "a 4×4 grid", drawn as a mesh). It is titled by its points and each point
    is a marker at its rates, coloured by its value; a full grid written as a list stays a
    mesh of cells."""
    stacked = datasets["error_map"].stack(point=("dtheta1", "dtheta2")).reset_index("point")
    picked, seen1, seen2 = [], set(), set()         # 3 points with a gait, no value shared
    for k in np.flatnonzero(stacked["status"].values == 0):
        d1, d2 = float(stacked["dtheta1"][k]), float(stacked["dtheta2"][k])
        if len(picked) < 3 and d1 not in seen1 and d2 not in seen2:
            picked.append(k)
            seen1.add(d1)
            seen2.add(d2)
    three = stacked.isel(point=picked)                  # 6 of its 9 cells blank
    assert len(set(three["dtheta1"].values)) == len(set(three["dtheta2"].values)) == 3
    for fig in (plot_error_map(three), plot_swap_time_map(three), plot_error_surface(three)):
        title = fig._suptitle.get_text()
        assert "3 listed points" in title and "grid" not in title, title
    points = np.column_stack([three["dtheta1"].values, three["dtheta2"].values])
    for fig, gid, name in ((plot_error_map(three), "error", "error"),
                           (plot_swap_time_map(three), "t_switch", "t_switch")):
        drawn = by_gid(fig, gid)
        assert isinstance(drawn, PathCollection), type(drawn)      # markers, not a mesh
        np.testing.assert_allclose(np.sort(drawn.get_offsets(), axis=0),
                                   np.sort(points, axis=0))
        order = np.lexsort(points.T[::-1])
        got = np.lexsort(np.asarray(drawn.get_offsets()).T[::-1])
        want = three[name].values[order]
        if name == "error":
            want = np.minimum(want, 5.0)
        np.testing.assert_allclose(np.asarray(drawn.get_array())[got], want)
    # every cell of a full grid written as a list holds a point: cells, as for a grid
    assert isinstance(by_gid(plot_error_map(stacked), "error"), QuadMesh)


def test_the_lowest_error_of_a_lone_row_is_shown(datasets):
    """A grid of one dtheta2 row (a 1 x 1 grid, or an N x 1 one): the side panel's line of
    each row's lowest error had one point and drew nothing, and the labels of its ticks within
    one decade ran into each other."""
    grid = datasets["error_map"]
    j = int(np.flatnonzero((grid["status"] == 0).any("dtheta1").values)[0])
    row = grid.isel(dtheta2=[j])
    fig = plot_error_map(row)
    dots = by_gid(fig, "row_minimum_points")
    lowest = float(row["error"].where(row["status"] == 0).min())
    np.testing.assert_allclose(dots.get_xdata(), [lowest])
    np.testing.assert_allclose(dots.get_ydata(), row["dtheta2"].values)
    panel = dots.axes
    fig.canvas.draw()
    assert not any(t.get_text() for t in panel.xaxis.get_minorticklabels())


def test_the_animation_legend_shows_each_stage_in_the_colour_the_robot_is_drawn(
        datasets, tmp_path, monkeypatch):
    """The animation's legend gave "motor on" vermillion (the motor-on colour of a
    robot hanging from A) while the horizontal gait's robot, hanging from B with its motor
    on, is drawn amber. Each stage the run passes through has a legend line of the colour
    and words of :data:`STAGES`, and no legend line has a stage colour the run never shows."""
    from monkeystudy.plotting import gait

    figures, made = [], gait.new_figure

    def keep(**kwargs):
        figures.append(made(**kwargs))
        return figures[-1]

    monkeypatch.setattr(gait, "new_figure", keep)
    s = datasets["stability_1"]
    write_animation(s, tmp_path / "anim", {}, max_frames=4, fps=2, fmt="gif")
    stages = set(trajectory(s).stage)
    assert "B+motor" in stages                    # the horizontal gait's motor phase
    legend = figures[0].legends[0]
    drawn = {}
    for line, text in zip(legend.get_lines(), legend.get_texts()):
        drawn[text.get_text()] = line.get_color()
    stage_colours = {colour for colour, _ in gait.STAGES.values()}
    for key in stages:
        colour, words = gait.STAGES[key]
        assert drawn.get(words) == colour, (key, drawn)
    shown = {c for c in drawn.values() if c in stage_colours}
    assert shown == {gait.STAGES[k][0] for k in stages}, drawn


def test_filmstrip_text_is_readable_on_the_page_and_frame_numbers_inside_the_timeline(
        datasets):
    """The 12-inch filmstrip (1800 px at 150 dpi) was scaled to the page's 1100 px,
    leaving 7-pt text 8.9 px high and less; the numbers of the first and last frames were cut
    at the timeline's ends. Every text is at least 10 px high at the page's width and every
    frame number lies inside the timeline."""
    import matplotlib

    from monkeystudy.plotting.common import PAGE_WIDTH_PX, style

    with style():
        dpi = float(matplotlib.rcParams["savefig.dpi"])
    fig = plot_filmstrip(datasets["stability_1"])
    fig.canvas.draw()
    shown = min(1.0, PAGE_WIDTH_PX / (fig.get_figwidth() * dpi))    # page / figure
    texts = [t for t in fig.findobj(lambda a: hasattr(a, "get_fontsize")
                                    and hasattr(a, "get_text"))
             if t.get_visible() and t.get_text().strip()]
    smallest = min(t.get_fontsize() for t in texts)
    assert smallest * dpi / 72.0 * shown >= 10.0, smallest
    numbers = [a for a in fig.findobj() if a.get_gid() == "frame_number"]
    assert len(numbers) >= 8
    renderer = fig.canvas.get_renderer()
    box = numbers[0].axes.get_window_extent(renderer)
    for n in numbers:
        ext = n.get_window_extent(renderer)
        assert box.x0 <= ext.x0 and ext.x1 <= box.x1, (n.get_text(), ext, box)


def test_the_e_one_line_of_a_row_above_one_is_labelled_inside_the_panel(datasets):
    """A lone row whose lowest error is above 1 put e = 1 at the side panel's left
    edge and its label outside the panel."""
    grid = datasets["error_map"]
    j = int(np.flatnonzero((grid["status"] == 0).any("dtheta1").values)[0])
    row = grid.isel(dtheta2=[j])
    row["error"] = row["error"] + 3.0                     # every error of the row above 1
    fig = plot_error_map(row)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    axp = by_gid(fig, "row_minimum").axes
    label, = [t for t in axp.texts if t.get_text() == "e = 1"]
    panel = axp.get_window_extent(renderer)
    ext = label.get_window_extent(renderer)
    assert panel.x0 <= ext.x0 and ext.x1 <= panel.x1, (ext, panel)
    lo, hi = label.axes.get_xlim()
    assert lo < 1.0 < hi


def test_durations_read_in_seconds_from_one_second(datasets):
    """A motor phase of 2.69 s read "motor on for 2.69e+03 ms"."""
    from monkeystudy.plotting.labels import duration

    assert duration(0.031) == "31 ms"
    assert duration(2.69) == "2.69 s"
    assert duration(float("nan")) == "–"
    grid = datasets["error_map"].copy()
    grid["t_motor"] = grid["t_motor"] * 0.0 + 2.69
    legend = [t.get_text() for leg in plot_error_map(grid).legends for t in leg.get_texts()]
    assert any("motor on for 2.69 s" in t for t in legend), legend


def test_labels_of_the_least_error_and_a_minimum_on_it_are_clear_of_every_marker(datasets):
    """A refined minimum on (or beside) the grid's least error lay under its star,
    its number under the star's "least e". The squares are drawn over the star and every
    label lies inside the map, clear of every marker and of every other label."""
    grid = datasets["error_map"]
    g = grid_arrays(grid)
    i, j = np.unravel_index(np.nanargmin(np.where(g.ok, g.error, np.nan)), g.error.shape)
    on, near = datasets["refine_1"].copy(), datasets["refine_2"].copy()
    on["dtheta1"], on["dtheta2"] = ((), float(g.dtheta1[i])), ((), float(g.dtheta2[j]))
    step = float(g.dtheta1[1] - g.dtheta1[0]) * 0.2
    near["dtheta1"], near["dtheta2"] = ((), float(g.dtheta1[i]) + step), \
        ((), float(g.dtheta2[j]))
    for fig in (plot_error_map(grid, [on, near]), plot_swap_time_map(grid, [on, near])):
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        star = by_gid(fig, "least_error")
        squares = [a for a in fig.findobj() if str(a.get_gid()).startswith("minimum_")]
        labels = [a for a in fig.findobj() if str(a.get_gid()).startswith("label_")]
        labels.append(by_gid(fig, "least_error_label"))
        assert len(squares) == 2 and len(labels) == 3
        assert all(sq.get_zorder() > star.get_zorder() for sq in squares)
        box = star.axes.get_window_extent(renderer)
        marks = [m.get_window_extent(renderer) for m in squares + [star]]
        texts = [Text.get_window_extent(t, renderer) for t in labels]     # the words alone
        for k, t in enumerate(texts):
            assert box.x0 <= t.x0 and t.x1 <= box.x1 and box.y0 <= t.y0 and t.y1 <= box.y1
            for other in marks + texts[:k] + texts[k + 1:]:
                assert not t.overlaps(other), (labels[k].get_text(), t, other)
