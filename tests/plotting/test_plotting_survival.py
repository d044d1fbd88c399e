"""Figures of the survival step (monkeystudy.plotting.kinds.survival) on a real dataset: a
short survival run of the 2009 gait with every noise source on at its second level."""
from __future__ import annotations

import re
import warnings

import numpy as np
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


def _extent(artist):
    return artist.get_window_extent(artist.figure.canvas.get_renderer())


def test_the_height_drift_legend_lies_off_the_histogram(every_source):
    """The legend (loc "best") sat on the histogram's peak: no free corner in the axes."""
    fig = plot_height_drift(every_source)
    fig.canvas.draw()
    legends = fig.findobj(Legend)
    assert legends
    ax = next(a for a in fig.findobj() if str(a.get_gid()).startswith("height_drift_")).axes
    for leg in legends:
        assert not _extent(leg).overlaps(ax.get_window_extent()), "a legend in the axes"


def test_a_survival_of_0993_stands_off_no_failure(every_source):
    """On a 0-1 survival axis 7 failures in 1000 runs lay 0.7 % of the axes' height below
    the line of no failure: the curve looked flat."""
    ds = every_source.copy(deep=True)
    surv = np.ones(ds["survival"].shape)
    surv[:, -1] = 0.993
    ds["survival"] = (ds["survival"].dims, surv)
    ds.attrs["runs"] = 1000
    fig = plot_survival(ds)
    fig.canvas.draw()
    line = next(a for a in fig.findobj() if a.get_gid() == "survival_0")
    ax = line.axes
    y = ax.transData.transform(np.column_stack(line.get_data()))[:, 1]
    assert y.max() - y.min() >= 0.1 * ax.get_window_extent().height


def test_failure_counts_are_written_and_a_few_failures_are_seen(every_source):
    """7 failures in 1000 runs were invisible slivers of the bar, without a count."""
    from monkeystudy.plotting.kinds.survival import LEAST_SHARE

    ds = every_source.copy(deep=True)
    modes = [str(m) for m in ds["failure_mode"].values]
    counts = np.zeros(ds["failure_count"].shape, int)
    counts[:, modes.index("survived")] = 993
    counts[:, modes.index("horizon")] = 1
    counts[:, modes.index("stalled")] = 6
    ds["failure_count"] = (ds["failure_count"].dims, counts)
    fig = plot_failure_modes(ds)
    fig.canvas.draw()
    written = " ".join(t.get_text() for t in fig.findobj(Text)
                       if str(t.get_gid()).startswith("mode_counts_"))
    for text in ("993 survived", "1 horizon", "6 stalled"):
        assert written.count(text) == ds.sizes["level"], (text, written)
    ax = fig.axes[0]
    per_pt = ax.get_window_extent().width / fig.dpi * 72.0     # points of a share of 1
    for mode in ("horizon", "stalled"):
        bars = [a for a in fig.findobj() if a.get_gid() == f"mode_{mode}"]
        assert len(bars) == ds.sizes["level"]
        for patch in bars:
            assert patch.get_width() >= LEAST_SHARE - 1e-12 and patch.get_width() * per_pt >= 4


def _lines(fig):
    return [line for leg in fig.findobj(Legend) for t in leg.get_texts()
            for line in t.get_text().split("\n")]


def _same_noise(every_source, name_a: str):
    one = every_source.isel(level=[1])
    one.attrs.update(swept="[]")
    a, b = one.copy(), one.copy()
    a.attrs["step_name"], b.attrs["step_name"] = name_a, "b"
    return [a, b]


def test_no_value_in_the_comparison_legend_leaves_its_unit(every_source):
    """The legend broke "com 1 %" across lines."""
    from monkeystudy.plotting.kinds.survival import SOURCES, SHOWN_UNITS

    # a line ending in a source's name or a number, or starting with a unit
    broken_name = re.compile(r"(\b(" + "|".join(SOURCES) + r")|\d)\s*$")
    broken_unit = re.compile(r"^\s*(" + "|".join(re.escape(u) for u, _ in
                                                SHOWN_UNITS.values()) + r")\b")
    for k in range(1, 40):          # step names that move every break along the label
        fig = plot_mfpt_comparison(_same_noise(every_source, "a" * k))
        fig.canvas.draw()
        for line in _lines(fig):
            assert not broken_name.search(line) and not broken_unit.search(line), line


def test_steps_at_the_same_noise_are_drawn_side_by_side(every_source):
    """Two gaits' lower bounds at 1 ms: the one arrow hidden under the other."""
    fig = plot_mfpt_comparison(_same_noise(every_source, "a"))
    fig.canvas.draw()
    xs = []
    for name in ("a", "b"):
        mark = next(m for m in fig.findobj() if m.get_gid() in (f"mfpt_{name}_bound",
                                                                 f"mfpt_{name}"))
        xs.append(mark.get_transform().transform(np.column_stack(mark.get_data()))[0, 0])
    assert abs(xs[0] - xs[1]) >= 10, xs


def test_the_subtitle_names_each_sources_distribution(every_source):
    """The subtitle said "gaussian noise (at every level: ..., latency 0.1 ms)": the latency
    is drawn once per run uniformly whatever the distribution."""
    ds = every_source.isel(level=[1])
    ds.attrs.update(swept="[]", noise_distribution="gaussian")
    texts = [t.get_text().replace("\n", " ") for t in plot_survival(ds).findobj(Text)]
    subtitle = next(t for t in texts if "gaussian" in t)
    gaussian = subtitle.split("gaussian", 1)[1].split(";", 1)[0]
    assert "timing" in gaussian and "latency" not in gaussian, subtitle
    assert re.search(r"latency drawn once per run uniformly on \[0,\s0\.1\s+ms\)", subtitle), \
        subtitle


def _no_mfpt(ds, name):
    zero = ds.copy(deep=True)
    for v in ("mfpt", "mfpt_low", "mfpt_high"):
        zero[v] = zero[v] * 0.0
    zero["mfpt_method"] = zero["mfpt_method"] * 0
    zero.attrs["step_name"] = name
    return zero


def test_every_mfpt_0_skips_the_figure_saying_why(every_source):
    """Every MFPT 0 cycles drew an empty log axis (matplotlib: "Data has no positive
    values")."""
    from monkeystudy.plotting.drawing import NothingToDraw
    from monkeystudy.plotting.kinds.survival import plot_mfpt

    zero = _no_mfpt(every_source, "zero")
    with pytest.raises(NothingToDraw, match="MFPT is 0 cycles"):
        plot_mfpt(zero)
    with pytest.raises(NothingToDraw, match="MFPT is 0 cycles"):
        plot_mfpt_comparison([zero, _no_mfpt(every_source, "nil")])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fig = plot_mfpt_comparison([zero, every_source])
        fig.canvas.draw()
    assert not [a for a in fig.findobj() if str(a.get_gid()).startswith("mfpt_zero")]
    assert any("not shown (every MFPT 0 cycles): zero" in t.get_text().replace("\n", " ")
               for t in fig.findobj(Text))


#: a step name as long as the schema allows
LONG_NAME = ("Survival_Of_The_Designed_Gait_" * 4)[:100]


def fits_in_the_figure(fig) -> None:
    """No warning while the figure is laid out and drawn, and everything drawn lies within
    it."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")              # a collapsed layout warns
        fig.canvas.draw()
    drawn = fig.get_tightbbox(fig.canvas.get_renderer())                     # inches
    width, height = fig.get_size_inches()
    assert drawn.x0 >= -0.02 and drawn.x1 <= width + 0.02, (drawn, width)
    assert drawn.y0 >= -0.02 and drawn.y1 <= height + 0.02, (drawn, height)


def test_a_step_name_of_100_characters_keeps_the_figure_whole(every_source):
    """The title, one word of 100 characters after "Survival under noise:", ran off the
    figure."""
    assert len(LONG_NAME) == 100
    ds = every_source.copy()
    ds.attrs["step_name"] = LONG_NAME
    for plot in (plot_survival, plot_failure_modes, plot_height_drift):
        fits_in_the_figure(plot(ds))


def test_levels_that_no_one_noise_orders_are_drawn_by_level_not_joined(every_source):
    """Four levels, jitter 0.01 and 0.1 ms each without and with the other sources: along
    the jitter axis the line joined a level with the other sources to one without, and read
    as jitter's effect. They are drawn against the level, each named under its tick, and not
    joined; levels that grow together keep the noise axis."""
    from matplotlib.lines import Line2D

    from monkeystudy.plotting.kinds.survival import LEVEL_AXIS, noise_axis, plot_mfpt

    assert noise_axis(every_source)[0] == "timing"
    crossed = every_source.isel(level=[0, 0, 1, 1]).copy(deep=True)
    crossed["noise_timing"].values[:] = [1e-5, 1e-4, 1e-5, 1e-4]
    source, x, label = noise_axis(crossed)
    assert source == LEVEL_AXIS and list(x) == [0, 1, 2, 3] and label == "noise level"
    for fig in (plot_mfpt(crossed), plot_mfpt_comparison([crossed])):
        fig.canvas.draw()
        ax = next(a for a in fig.axes if a.get_xlabel() == "noise level")
        ticks = [t.get_text() for t in ax.get_xticklabels()]
        assert len(ticks) == 4 and all(t.startswith("timing") for t in ticks), ticks
        assert ticks[0] != ticks[2]                   # the other sources name the level
        joined = [ln for ln in ax.findobj(Line2D)
                  if ln.get_linestyle() not in ("None", "none", "") and len(ln.get_xdata()) > 2]
        assert not joined
