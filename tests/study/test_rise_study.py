"""A study whose sequence gait has a ``rise`` (studies/descending_design.yaml, made small):
every dataset states the rise [m], the floquet step's full map measures the height from the
staircase (its height multiplier 0), and the survival step's height drift and
height_tolerance compare each run's last catch with the staircase, not with the start."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from monkeystudy.kernel import layout as L
from monkeystudy.study import load_study, run_study

ROOT = Path(__file__).resolve().parents[2]

SMALL = """\
schema_version: 1
name: descending_small
robot: seed2009
gait:
  kind: sequence
  torque_frame: motor
  rise: -0.1
  section: {theta1: 0.0, direction: either, theta2: -1.2410195771999732}
  segments:
    - {until: time, value: 7.519090701371105e-08}
    - {until: free_end_y, value: -0.1, direction: rising, torque: -0.2118, clock: reset}
    - {until: time, value: 0.2, magnets: swap, torque: 0.2118}
integrator: {method: dop853, rtol: 1.0e-12, atol: 1.0e-13, max_time: 3.0}
steps:
  - {name: refine, kind: refine, start: [3.141805394182587, 7.739977215255691], maxiter: 40}
  - {name: floquet, kind: floquet, from: refine, height_in_map: true}
  - name: survival
    kind: survival
    from: floquet
    controller: {tick: 0.001}
    runs: 6
    max_cycles: 30
    seed: 30
    height_tolerance: 0.02
    noise: {timing: 1.0e-3, latency: 1.0e-3}
  - {name: link1_com, kind: continuation, from: floquet, parameter: link1_com, ds: 0.05,
     steps: 2, bounds: [0.52744, 0.56007]}
  - {name: torque, kind: continuation, from: floquet, parameter: torque, ds: 0.05, steps: 1}
"""


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    folder = tmp_path_factory.mktemp("rise")
    path = folder / "descending_small.yaml"
    path.write_text(SMALL)
    out = folder / "out"
    run_study(load_study(path), out=out, workers=1)
    data = {}
    for name in ("refine", "floquet", "survival", "link1_com", "torque"):
        with xr.open_dataset(out / f"{name}.nc") as ds:
            data[name] = ds.load()
    return data


def test_every_dataset_states_the_rise(small):
    for name, ds in small.items():
        assert float(ds.attrs["rise"]) == -0.1, name
        assert json.loads(ds.attrs["gait"])["rise"] == -0.1, name


def test_the_full_map_holds_the_height_on_the_staircase(small):
    ds = small["floquet"]
    J = ds["full_jacobian"].values[0]
    assert np.max(np.abs(J[0])) < 1e-12                  # the catch sets the next height
    lam = np.abs(ds["full_multipliers_real"].values[0]
                 + 1j * ds["full_multipliers_imag"].values[0])
    assert lam.min() < 1e-12
    rho = float(ds["full_spectral_radius"].values[0])
    assert rho == pytest.approx(0.2281549, abs=1e-6)
    assert float(ds["full_agreement"].values[0]) < 1e-6
    assert "planned height" in ds["full_jacobian"].attrs["long_name"]


def test_survival_measures_each_run_from_the_staircase(small):
    """The runs go 3 m down in 30 steps; a late catch (latency, jitter) leaves its end off
    the staircase by millimetres, and the next catch is on it again: every run's drift from
    the staircase is within the 0.02 m tolerance (from the start it would be -3 m), and the
    default fall (link 1's length below the planned height) ends none."""
    ds = small["survival"]
    assert (ds["failure"].values == L.ST_OK).all()
    drift = ds["height_drift"].values
    assert np.max(np.abs(drift)) < 0.02
    assert np.max(np.abs(drift)) > 0.0                   # the noise moves the catch
    assert float(ds["height_within_tolerance"].values[0]) == 1.0
    assert "planned height" in ds["height_drift"].attrs["long_name"]


def test_the_shipped_studies_catch_on_their_staircase():
    for name, rise in (("descending_design", -0.1), ("climbing_design", 0.02)):
        gait = load_study(ROOT / "studies" / f"{name}.yaml").study.gait
        assert gait.rise == rise
        catches = [s for s in gait.segments if s.until == "free_end_y"]
        assert [s.value for s in catches] == [rise]


def test_a_links_own_cg_is_continued_on_the_cycle_of_two_steps(small):
    """Link 1's CG alone makes the links differ: the branch is of the cycle of two steps,
    two rises down, and at the start its multipliers are the floquet step's squared."""
    ds = small["link1_com"]
    assert ds.attrs["steps_per_cycle"] == 2 and ds.attrs["parameter_units"] == "m"
    assert ds["parameter_value"].values[0] == pytest.approx(0.543754, abs=1e-12)
    assert np.all(np.diff(ds["parameter_value"].values) > 0)
    assert ds["y_advance"].values[0] == pytest.approx(-0.2, abs=1e-9)
    fq = small["floquet"]
    one = fq["multipliers_real"].values[0] + 1j * fq["multipliers_imag"].values[0]
    two = ds["multipliers_real"].values[0] + 1j * ds["multipliers_imag"].values[0]
    assert np.sort_complex(two) == pytest.approx(np.sort_complex(one ** 2), abs=1e-7)
    # the motor's torque leaves the links mirror images: one step per cycle, as the floquet's
    tq = small["torque"]
    assert tq.attrs["steps_per_cycle"] == 1
    lam = tq["multipliers_real"].values[0] + 1j * tq["multipliers_imag"].values[0]
    assert np.sort_complex(lam) == pytest.approx(np.sort_complex(one), abs=1e-7)
