"""Figures of the design step (monkeystudy.plotting.kinds.design) on real datasets: a
sequence gait's design (the catch at the start's height, studies/robust_design.yaml's gait)
with the least screen, one candidate run once, and over a 2 x 2 grid of two torques."""
from __future__ import annotations

import re

import numpy as np
import pytest
import xarray as xr
from matplotlib.colors import to_hex
from matplotlib.legend import Legend
from matplotlib.text import Text

from monkeystudy.plotting.kinds.design import plot_design_map, plot_design_screen

LEAST_SCREEN = """\
schema_version: 1
name: least_screen
robot: seed2009
gait:
  kind: sequence
  torque_frame: motor
  section: {theta1: 0.0, direction: either, theta2: 0.43}
  segments:
    - {until: time, value: 7.519090701371105e-08}
    - {until: free_end_y, value: 0.0, direction: rising, torque: 0.3213454663367762,
       clock: reset}
    - {until: time, value: 0.28929574705023964, magnets: swap, torque: -0.40251722486466324}
integrator: {method: dop853, rtol: 1.0e-12, atol: 1.0e-13}
steps:
  - {name: r, kind: refine, start: [4.8, -1.6], xatol: 1.0e-10, fatol: 1.0e-18, maxiter: 2000,
     maxfev: 4000}
  - {name: f, kind: floquet, from: r, height_in_map: true}
  - name: d
    kind: design
    from: f
    parameters:
      segment2_torque: {start: 0.30, stop: 0.34, num: 2}
    refine: {starts: 0}
    screen: {candidates: 1, runs: 1, max_cycles: 2, noise: {timing: 1.0e-3}}
    verify: {cycles: 2, decay_cycles: 3, basin_num: 2, basin_cycles: 1}
"""


@pytest.fixture(scope="module")
def least_screen(tmp_path_factory) -> xr.Dataset:
    from monkeystudy.study import parse_study, run_study

    out = tmp_path_factory.mktemp("design") / "out"
    run_study(parse_study(LEAST_SCREEN, "least_screen.yaml"), out, workers=1)
    with xr.open_dataset(out / "d.nc") as ds:
        return ds.load()


def test_a_screen_of_one_run_counts_in_the_singular(least_screen):
    """The subtitle said "1 candidate, each 1 runs of up to 2 cycles"."""
    assert int(least_screen.attrs["screen_runs"]) == 1
    texts = [t.get_text() for t in plot_design_screen(least_screen).findobj(Text)]
    assert any("1 candidate, each 1 run of up to 2 cycles on the" in t for t in texts), texts
    assert not any(re.search(r"(?<![\d.])1 (runs|candidates)\b", t) for t in texts), texts


#: the same gait over a 2 x 2 grid of two torques: a map with two axes
TWO_TORQUES = LEAST_SCREEN.replace(
    "      segment2_torque: {start: 0.30, stop: 0.34, num: 2}\n",
    "      segment2_torque: {start: 0.30, stop: 0.34, num: 2}\n"
    "      segment3_torque: {start: -0.42, stop: -0.38, num: 2}\n").replace(
    "    screen: {candidates: 1, runs: 1, max_cycles: 2, noise: {timing: 1.0e-3}}\n", "")


@pytest.fixture(scope="module")
def two_torques(tmp_path_factory) -> xr.Dataset:
    from monkeystudy.study import parse_study, run_study

    out = tmp_path_factory.mktemp("design") / "out"
    run_study(parse_study(TWO_TORQUES, "two_torques.yaml"), out, workers=1)
    with xr.open_dataset(out / "d.nc") as ds:
        return ds.load()


def _crossing_one(ds) -> xr.Dataset:
    """``ds`` with spectral radii on both sides of 1 (the contour drawn), a gait at every
    design."""
    out = ds.copy(deep=True)
    rho = out["spectral_radius"]
    out["spectral_radius"] = (rho.dims, np.array([[0.5, 2.0], [0.8, 3.0]]).reshape(rho.shape))
    return out


def _map_parts(fig):
    ax = next(a for a in fig.findobj() if a.get_gid() == "rho_map").axes
    return ax, {a.get_gid(): a for a in ax.get_children() if a.get_gid()}


def test_the_rho_one_contour_is_in_the_legend_in_its_colour_and_no_subtitle_names_another(
        two_torques):
    """The subtitle said the rho = 1 contour is orange; it was drawn vermillion."""
    fig = plot_design_map(_crossing_one(two_torques))
    fig.canvas.draw()
    ax, parts = _map_parts(fig)
    contour = to_hex(parts["rho_one"].get_edgecolor()[0])
    entries = {t.get_text(): h for leg in fig.findobj(Legend)
               for t, h in zip(leg.get_texts(), leg.legend_handles)}
    one = [h for text, h in entries.items() if text.startswith("ρ = 1")]
    assert len(one) == 1 and to_hex(one[0].get_color()) == contour, entries
    words = " ".join(t.get_text() for t in fig.findobj(Text))
    assert not re.search(r"\b(red|orange|vermillion|blue|green)\b", words), words


def test_the_map_legend_lies_off_the_designs_and_the_title_on_one_line(two_torques):
    """The legend covered the top row of designs; the title wrapped its last word."""
    for height in (0, 1):
        ds = two_torques.copy()
        ds.attrs["height_in_map"] = height
        fig = plot_design_map(ds)
        fig.canvas.draw()
        ax, _ = _map_parts(fig)
        for leg in fig.findobj(Legend):
            assert not leg.get_window_extent().overlaps(ax.get_window_extent())
        title = fig.get_suptitle()
        assert title.startswith("Spectral radius") and "\n" not in title, title


def test_the_grid_best_rings_a_best_design_at_the_same_point(two_torques):
    """A best design at the grid's best: the star hid the grid's square."""
    ds = two_torques.copy()
    fig = plot_design_map(ds)
    _, parts = _map_parts(fig)
    gx, gy = (float(v[0]) for v in parts["grid_best"].get_data())
    names = [d for d in ds["status"].dims]
    xd, yd = names[1], names[0]
    ds.attrs.update({f"best_{xd}": gx, f"best_{yd}": gy})
    fig = plot_design_map(ds)
    fig.canvas.draw()
    _, parts = _map_parts(fig)
    square, star = (parts[g].get_window_extent() for g in ("grid_best", "best"))
    assert square.x0 < star.x0 and star.x1 < square.x1, (square, star)
    assert square.y0 < star.y0 and star.y1 < square.y1, (square, star)


def test_the_screen_names_its_axis_and_noise_in_words_and_units(least_screen):
    """The y axis read "runs that completed max_cycles", the noise "timing 0.001"."""
    fig = plot_design_screen(least_screen)
    label = fig.axes[0].get_ylabel()
    assert "max_cycles" not in label and "all 2 cycles" in label, label
    texts = " ".join(t.get_text() for t in fig.findobj(Text)).replace("\n", " ")
    assert re.search(r"timing\s1\sms", texts), texts


def _filmstrip(ds):
    from monkeystudy.plotting.gait import plot_filmstrip
    from monkeystudy.plotting.kinds.design import best_rates, has_film

    assert has_film(ds)
    fig = plot_filmstrip(ds, gait=best_rates(ds))
    fig.canvas.draw()
    return fig


def test_the_filmstrip_shows_each_time_once(least_screen):
    """A stage that began 75 ns after the start gave two frames at t = 0.000 s, their
    timeline marks one on the other."""
    fig = _filmstrip(least_screen)
    times = [re.search(r"t = ([\d.]+) s", ax.get_title()).group(1) for ax in fig.axes[:-1]]
    assert len(times) == len(set(times)), times
    timeline = fig.axes[-1]
    marks = [t.get_window_extent() for t in timeline.texts if t.get_text().isdigit()]
    assert len(marks) == len(times)
    for k, a in enumerate(marks):
        for b in marks[k + 1:]:
            assert not a.overlaps(b), (a, b)


def test_the_filmstrip_names_the_ends_inside_the_first_frame(least_screen):
    """End B's name, below it, ran out of the frame into the next row's title."""
    fig = _filmstrip(least_screen)
    first = fig.axes[0]
    names = [t for t in first.texts if t.get_text() in ("A", "B")]
    assert len(names) == 2
    inside = first.get_window_extent()
    for name in names:
        box = name.get_window_extent()
        assert inside.x0 <= box.x0 and box.x1 <= inside.x1, name.get_text()
        assert inside.y0 <= box.y0 and box.y1 <= inside.y1, name.get_text()


def test_study_and_step_names_of_100_characters_keep_the_design_figures_whole(least_screen):
    """The run lines end with the study and step names, each up to 100 characters in one
    word: the filmstrip's ran off the figure."""
    from monkeystudy.plotting.kinds.design import best_rates, plot_design_replay
    from monkeystudy.plotting.gait import plot_filmstrip
    from test_plotting_survival import LONG_NAME, fits_in_the_figure

    ds = least_screen.copy()
    ds.attrs.update(step_name=LONG_NAME, study_name=LONG_NAME.lower())
    for fig in (plot_design_screen(ds), plot_design_map(ds), plot_design_replay(ds),
                plot_filmstrip(ds, gait=best_rates(ds))):
        fits_in_the_figure(fig)
