"""Figures of the design dataset: what their text says. The dataset is real: a one-design
grid around the 2009 robot's schedule (studies/open_loop_design_smoke.yaml's), run by the
study runner (seconds)."""
from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr
from matplotlib.legend import Legend
from matplotlib.text import Text

from monkeystudy.plotting.kinds.design import plot_design_replay

#: one design of the smoke study's schedule, checked with a short replay and decay run
ONE_DESIGN = """\
schema_version: 1
name: one_design
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.0}
integrator: {method: dop853, rtol: 1.0e-8, atol: 1.0e-10, max_time: 3.0}
steps:
  - {name: shoot, kind: shoot, starts: [[1.44, 10.31], [1.0, 12.0]], method: grazing}
  - name: schedule
    kind: design
    from: shoot
    parameters: {motor_start: {start: -0.25, stop: -0.25, num: 1}}
    fixed: {torque: -0.6354, t_motor: 0.2}
    starts: [[-0.3288, 4.7564, 5.3654, 0.4711]]
    refine: {starts: 0}
    verify: {cycles: 3, decay_cycles: 4, basin_num: 1, basin_cycles: 1}
"""


@pytest.fixture(scope="module")
def design(tmp_path_factory) -> xr.Dataset:
    from monkeystudy.study import parse_study, run_study

    out = tmp_path_factory.mktemp("design") / "one_design"
    run_study(parse_study(ONE_DESIGN, "one_design.yaml"), out, workers=1)
    with xr.open_dataset(out / "schedule.nc") as ds:
        return ds.load()


def texts(fig) -> list[str]:
    return [t.get_text() for t in fig.findobj(Text)]


def test_the_decay_run_is_labelled_with_its_fitted_growth(design):
    growth = float(design.attrs["decay_growth"])
    assert math.isfinite(growth)
    assert f"perturbed run (fitted {growth:.4g} / cycle)" in texts(plot_design_replay(design))


def test_a_decay_run_without_a_fitted_growth_says_so(design):
    """Fewer than 3 cycles of the decay run inside the fitting window (a perturbation that
    leaves it at once, or a run that falls): the growth is NaN, and the label says it was
    not fitted rather than "fitted nan / cycle"."""
    unfitted = design.copy()
    unfitted.attrs["decay_growth"] = math.nan
    labels = texts(plot_design_replay(unfitted))
    assert not any("nan" in t for t in labels), labels
    assert "perturbed run (growth not fitted: fewer than 3 cycles in its window)" in labels


def _by_gid(fig) -> dict:
    return {a.get_gid(): a for a in fig.findobj() if a.get_gid()}


def test_the_exact_timing_traces_are_drawn_over_the_ticks(design):
    """The exact-timing kinetic energy, steady, hid under the tick's noisy trace."""
    assert list(design["replay_tick"].values[:2]) == [0.0, 0.001]
    parts = _by_gid(plot_design_replay(design))
    for key in ("error", "kinetic_energy", "pivot_height"):
        assert parts[f"{key}_0"].get_zorder() > parts[f"{key}_1"].get_zorder(), key


def test_the_error_bound_is_drawn_over_the_traces_and_the_legend_off_them(design):
    """The error bound, dotted grey, lay under the tick's trace; the legend covered the
    exact-timing trace."""
    fig = plot_design_replay(design)
    fig.canvas.draw()
    parts = _by_gid(fig)
    bound = parts["error_bound"]
    ax = bound.axes
    lo, hi = ax.get_ylim()
    assert bound.get_ydata()[0] == float(design.attrs["error_bound"])
    assert lo < float(design.attrs["error_bound"]) < hi
    assert bound.get_zorder() > max(parts[f"error_{i}"].get_zorder() for i in (0, 1))
    legends = [leg for leg in fig.findobj(Legend)
               if any(t.get_text().startswith("exact timing") for t in leg.get_texts())]
    assert legends
    for a in (parts["error_0"].axes, parts["kinetic_energy_0"].axes,
              parts["pivot_height_0"].axes):
        assert not legends[0].get_window_extent().overlaps(a.get_window_extent())


def test_the_perturbation_panel_spans_the_runs_decades(design):
    """A run at its floor of 1e-12 and a prediction extrapolated to 1e-42: the axis ran to
    1e-42, the run squeezed into its top."""
    ds = design.copy(deep=True)
    ds["perturbation_distance"] = (ds["perturbation_distance"].dims,
                                   np.array([1e-3, 1e-8, 1e-12, 1e-12]))
    ds.attrs["multiplier_power"] = 1e-8
    fig = plot_design_replay(ds)
    fig.canvas.draw()
    ax = _by_gid(fig)["decay"].axes
    lo, hi = ax.get_ylim()
    assert 1e-13 <= lo <= 1e-12 and 1e-3 <= hi <= 1e-2, (lo, hi)
