"""Figures of the survival step (monkeystudy.plotting.kinds.survival) on a real dataset: a
short survival run of the 2009 gait with every noise source on at its second level."""
from __future__ import annotations

import warnings

import pytest
import xarray as xr
from matplotlib.legend import Legend
from matplotlib.text import Text

from monkeystudy.plotting.kinds.survival import (
    plot_failure_modes, plot_height_drift, plot_mfpt_comparison, plot_survival,
)

#: two levels, the second with all ten noise sources: its label is a long line
EVERY_SOURCE = """\
schema_version: 1
name: every_source
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
integrator: {rtol: 1.0e-8, atol: 1.0e-10}
steps:
  - {name: gait, kind: refine, start: [0.902, 10.935], maxiter: 5}
  - name: sv
    kind: survival
    from: gait
    runs: 3
    max_cycles: 3
    height_tolerance: 0.05
    noise:
      distribution: uniform
      timing: [1.0e-5, 1.0e-4]
      torque: [0.0, 0.01]
      latency: [0.0, 1.0e-4]
      sensor: {angle: [0.0, 1.0e-4]}
      parameters: {mass: [0.0, 0.01], com: [0.0, 0.01], inertia: [0.0, 0.01]}
      initial_state: {theta2: [0.0, 1.0e-4], dtheta1: [0.0, 1.0e-3], dtheta2: [0.0, 1.0e-3]}
"""


def test_every_noise_source_has_a_label_and_units_a_figure_shows():
    """The figures' noise sources are the declared ones, no more and no fewer, each shown in
    units scaled from its own."""
    from monkeystudy.analysis.survival import SOURCES as DECLARED
    from monkeystudy.plotting.kinds.survival import LABELS, SHOWN_UNITS, SOURCES

    assert set(LABELS) == {s.name for s in DECLARED}
    assert set(SOURCES) == set(LABELS)
    for s in DECLARED:
        assert SOURCES[s.name][0] == f"noise_{s.name}"
        assert SOURCES[s.name][2:] == SHOWN_UNITS[s.units]


@pytest.fixture(scope="module")
def every_source(tmp_path_factory) -> xr.Dataset:
    from monkeystudy.study import parse_study, run_study

    out = tmp_path_factory.mktemp("survival") / "out"
    run_study(parse_study(EVERY_SOURCE, "every_source.yaml"), out, workers=1)
    with xr.open_dataset(out / "sv.nc") as ds:
        return ds.load()


@pytest.mark.parametrize("plot", [plot_survival, plot_failure_modes, plot_height_drift])
def test_a_level_with_every_noise_source_fits_in_the_figure(every_source, plot):
    """The second level's label named ten sources on one line: the layout collapsed ("axes
    sizes collapsed to zero"), the legend ran off the figure's right edge and the failure
    modes' title ran into its subtitle."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")              # a collapsed layout warns
        fig = plot(every_source)
        fig.canvas.draw()
    # every artist drawn (the titles, the legend, the labels) lies within the figure
    drawn = fig.get_tightbbox(fig.canvas.get_renderer())                     # inches
    width, height = fig.get_size_inches()
    assert drawn.x0 >= -0.02 and drawn.x1 <= width + 0.02, (drawn, width)
    assert drawn.y0 >= -0.02 and drawn.y1 <= height + 0.02, (drawn, height)
    titles = [t for t in fig.findobj(Text) if t.get_text().startswith(
        ("Survival under noise", "How the runs ended", "Height change"))]
    subtitles = [t for t in fig.findobj(Text) if t.get_text().startswith("open-loop replay")]
    assert len(titles) == len(subtitles) == 1
    renderer = fig.canvas.get_renderer()
    assert not titles[0].get_window_extent(renderer).overlaps(
        subtitles[0].get_window_extent(renderer)), "the title runs into its subtitle"


def test_a_level_of_one_run_counts_it_in_the_singular(every_source):
    """The height-drift legend said "1 of 1 runs completed"."""
    one = every_source.isel(run=[0])
    texts = [t.get_text() for t in plot_height_drift(one).findobj(Text)]
    assert any("1 of 1 run completed" in t for t in texts), texts


def test_the_comparison_shows_a_step_without_noise_and_names_no_source_twice(every_source):
    """A survival step without noise (its MFPT at noise 0) got a log noise axis: the panel
    was empty ("Data has no positive values") with a legend entry for its marker. A step of
    single values (none swept) named the source of its axis again in its legend ("also
    timing 0.1 ms, ...")."""
    quiet = every_source.isel(level=[0])
    quiet["noise_timing"] = quiet["noise_timing"] * 0.0
    quiet.attrs.update(swept="[]", step_name="quiet")
    single = every_source.isel(level=[1])
    single.attrs.update(swept="[]", step_name="single")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig = plot_mfpt_comparison([quiet, single])
        fig.canvas.draw()
    marks = [a for a in fig.findobj() if str(a.get_gid()).startswith("mfpt_quiet")]
    assert marks, "no marker of the step without noise"
    for mark in marks:
        ax = mark.axes
        lo, hi = ax.get_xlim()
        assert ax.get_xscale() == "linear" and lo <= 0.0 <= hi
    labels = [t.get_text() for leg in fig.findobj(Legend) for t in leg.get_texts()]
    single_label = " ".join(t for t in labels if t.startswith("single:")).replace("\n", " ")
    assert "also" in single_label and "timing" not in single_label.split("also", 1)[1], labels
