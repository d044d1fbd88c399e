"""The atlas step: each gait of a route measured (its step, its full map's spectral radius, its
failure probability under noise) and the direct switches between them."""
from __future__ import annotations

import numpy as np
import pytest

from monkeystudy.study import parse_study
from monkeystudy.study.loader import StudyError

from steps.routestudy import (DX_LEVEL, GAITS, PERIOD_LEVEL, RHO_DESCEND, RHO_LEVEL,
                              ROUTE_STUDY)
from studyhelpers import assert_written_as_declared, open_dataset


def test_the_atlas_measures_each_gait_as_its_own_study_does(route_study):
    ds = open_dataset(route_study[1], "atlas.nc")
    assert list(ds["gait"].values) == ["level", "descend"]
    # the full map's spectral radius: the design and floquet steps' variational values
    assert float(ds["gait_spectral_radius"][0]) == pytest.approx(RHO_LEVEL, abs=1e-7)
    assert float(ds["gait_spectral_radius"][1]) == pytest.approx(RHO_DESCEND, abs=1e-7)
    assert float(ds["gait_spectral_radius_agreement"].max()) < 1e-6
    assert float(ds["gait_dx"][0]) == pytest.approx(DX_LEVEL, abs=1e-9)
    assert float(ds["gait_duration"][0]) == pytest.approx(PERIOD_LEVEL, abs=1e-9)
    np.testing.assert_allclose(ds["gait_dy"].values, [0.0, -0.1])
    # a level step's work is what its catch takes; a descent's motor absorbs energy
    assert float(ds["gait_energy"][0]) > 0.0 > float(ds["gait_energy"][1])
    assert (ds["gait_map_defect"].values < 1e-9).all()
    # no run failed: the estimate is 0 and the bound is the Clopper-Pearson bound of
    # 0 failures in runs x max_cycles steps
    steps = int(ds.attrs["runs"]) * int(ds.attrs["max_cycles"])
    assert (ds["gait_survival_failed"].values == 0).all()
    np.testing.assert_allclose(ds["gait_p_fail_upper"].values, 1 - 0.025 ** (1 / steps),
                               rtol=1e-9)


def test_a_direct_switch_between_the_level_and_the_descending_gait_fails(route_study):
    # the two gaits' section states lie far apart: the state one leaves is outside the other's
    # basin, every run fails in the first steps after the switch
    ds = open_dataset(route_study[1], "atlas.nc")
    pairs = list(zip(ds["switch_from"].values, ds["switch_to"].values))
    assert pairs == [("level", "descend"), ("descend", "level")]
    assert (ds["switch_runs"].values == 12).all()
    assert (ds["switch_failed"].values == 12).all()


def test_atlas_datasets_are_written_as_declared(route_study):
    assert_written_as_declared(route_study[1] / "atlas.nc", "atlas")


def test_a_switch_step_must_go_between_gaits_of_the_atlas():
    bad = ROUTE_STUDY.replace(
        "      - name: descend\n",
        "      - name: via\n"
        "        start: [0, 0, 0]\n"
        "        switch: {from: level, to: nowhere}\n"
        "        gait: {kind: sequence, segments: [{until: free_end_y, value: 0.0, "
        "direction: rising}, {until: time, value: 0.2, magnets: swap}]}\n"
        "      - name: descend\n")
    with pytest.raises(StudyError, match="switch names 'nowhere'"):
        parse_study(bad)


def test_an_atlas_gait_catches_at_a_planned_world_height():
    bad = ROUTE_STUDY.replace("{until: free_end_y, value: 0.0,", "{until: free_end_height, "
                              "value: 0.0,")
    with pytest.raises(StudyError, match="its catch must be a free_end_y guard"):
        parse_study(bad)
    assert GAITS in ROUTE_STUDY


def test_inspect_gives_each_gaits_mfpt_or_its_lower_bound():
    from monkeystudy.study.steps.atlas import mfpt_words
    row = {"gait_mfpt": 24.2536, "gait_mfpt_low": 16.609, "gait_mfpt_high": 33.9256,
           "gait_mfpt_censored": 0}
    assert mfpt_words(row) == "; MFPT 24.25 steps (16.61 to 33.93)"
    row.update(gait_mfpt=5620.7, gait_mfpt_censored=1)
    assert mfpt_words(row) == "; MFPT >= 5621 steps (no failure late in the runs)"
