"""Figures of the design step (monkeystudy.plotting.kinds.design) on a real dataset: a
sequence gait's design (the catch at the start's height, studies/robust_design.yaml's gait)
with the least screen, one candidate run once."""
from __future__ import annotations

import re

import pytest
import xarray as xr
from matplotlib.text import Text

from monkeystudy.plotting.kinds.design import plot_design_screen

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
