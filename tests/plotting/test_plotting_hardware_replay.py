"""Figures of the hardware_replay dataset: the artists carry the dataset's numbers (read back
by gid, not from pixels) and every declared figure is drawn. The dataset is real:
studies/acromonk_smoke.yaml run by the study runner (seconds)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from monkeystudy.plotting import plot_held_out, plot_parameters, plot_residuals, plot_swings

ROOT = Path(__file__).resolve().parents[2]
SMOKE = ROOT / "studies" / "acromonk_smoke.yaml"


@pytest.fixture(scope="module")
def ds(tmp_path_factory):
    from monkeystudy.study import load_study, run_study

    out = tmp_path_factory.mktemp("acromonk") / "acromonk_smoke"
    run_study(load_study(SMOKE), out, workers=2)
    with xr.open_dataset(out / "replay.nc") as d:
        return d.load()


def artists(fig, gid: str) -> list:
    found = [a for a in fig.findobj() if getattr(a, "get_gid", lambda: None)() == gid]
    assert found, f"no artist {gid!r}"
    return found


def test_held_out_bars_are_the_rms_errors_and_the_floor_is_drawn(ds):
    fig = plot_held_out(ds)
    held = [i for i, h in enumerate(ds["held_out"].values) if h]
    for m, model in enumerate(ds["model"].values):
        for j, joint in enumerate(ds["joint"].values):
            for k in range(ds.sizes["horizon"]):
                bars = artists(fig, f"rms_{model}_{joint}_{k}")
                np.testing.assert_array_equal([b.get_height() for b in bars],
                                              ds["rms_error"].values[m, held, j, k])
            bars = artists(fig, f"whole_{model}_{joint}")
            np.testing.assert_array_equal([b.get_height() for b in bars],
                                          ds["whole_swing_rms"].values[m, held, j])
    for j, joint in enumerate(ds["joint"].values):
        for k in range(ds.sizes["horizon"]):
            line = artists(fig, f"floor_{joint}_{k}")[0]
            assert line.get_ydata()[0] == ds["sensor_floor"].values[j, k]


def test_parameters_show_the_value_both_intervals_and_the_published_one(ds):
    fig = plot_parameters(ds)
    for k, name in enumerate(ds["parameter"].values):
        assert artists(fig, f"value_{name}")[0].get_ydata()[0] == \
            ds["identified_value"].values[k]
        np.testing.assert_array_equal(artists(fig, f"clustered_{name}")[0].get_ydata(),
                                      ds["ci95_clustered"].values[k])
        np.testing.assert_array_equal(artists(fig, f"independent_{name}")[0].get_ydata(),
                                      ds["ci95_independent"].values[k])
        assert artists(fig, f"published_{name}")[0].get_ydata()[0] == \
            ds["model_value"].values[1, k]


@pytest.mark.parametrize("held_out", [False, True])
def test_swings_draw_the_measured_and_the_replayed_series(ds, held_out):
    fig = plot_swings(ds, held_out=held_out)
    held = {lg for lg, h in zip(ds["log"].values, ds["held_out"].values) if h}
    drawn = [i for i, lg in enumerate(ds["swing_log"].values) if (lg in held) == held_out]
    assert drawn
    for i in drawn:
        s = ds["swing"].values[i]
        n = int(ds["swing_samples"].values[i])
        for j, joint in enumerate(ds["joint"].values):
            for what in ("angle", "rate"):
                for source in ("measured", "simulated"):
                    line = artists(fig, f"{source}_{what}_{s}_{joint}")[0]
                    np.testing.assert_array_equal(line.get_xdata(), ds["time"].values[i, :n])
                    np.testing.assert_array_equal(line.get_ydata(),
                                                  ds[f"{source}_{what}"].values[i, :n, j])


def test_residuals_are_simulated_less_measured(ds):
    fig = plot_residuals(ds)
    for i, s in enumerate(ds["swing"].values):
        n = int(ds["swing_samples"].values[i])
        for j, joint in enumerate(ds["joint"].values):
            y = artists(fig, f"whole_{s}_{joint}")[0].get_ydata()
            np.testing.assert_array_equal(y, ds["simulated_angle"].values[i, :n, j]
                                          - ds["measured_angle"].values[i, :n, j])
    held = {lg for lg, h in zip(ds["log"].values, ds["held_out"].values) if h}
    log_of = dict(zip(ds["swing"].values, ds["swing_log"].values))
    on_held = np.array([log_of[s] in held for s in ds["start_swing"].values])
    for j, joint in enumerate(ds["joint"].values):
        for k in range(ds.sizes["horizon"]):
            pts = artists(fig, f"starts_identified_{joint}_{k}")[0].get_offsets()
            np.testing.assert_array_equal(np.asarray(pts)[:, 1],
                                          ds["start_error"].values[0, on_held, j, k])


def test_the_page_shows_the_cgs_offsets_across_the_links(ds, tmp_path):
    # a robot whose CGs lie off its links' lines: the set-up table has their offsets, as the
    # dataset's robot attribute holds them; an in-line robot's table has no such column
    import json

    from monkeystudy.plotting.page import render_page
    from monkeystudy.plotting.report import DRAWINGS

    html = render_page(tmp_path, {"replay": ds}, {}, drawings=DRAWINGS)
    assert "CG across the link" in html
    for link in ("link1", "link2"):
        across = json.loads(ds.attrs["robot"])[link]["com_across"]
        assert f"<td>{across:.10g} m</td>" in html
    in_line = ds.copy()
    robot = json.loads(ds.attrs["robot"])
    for link in ("link1", "link2"):
        del robot[link]["com_across"]
    in_line.attrs["robot"] = json.dumps(robot)
    assert "CG across the link" not in render_page(tmp_path, {"replay": in_line}, {},
                                                   drawings=DRAWINGS)


def test_the_page_of_a_study_that_runs_no_gait_states_none(ds, tmp_path):
    # studies/acromonk_smoke.yaml runs no gait: its page's set-up says what the replays ran
    # (the dataset's replay integrator), never a gait or the study's integrator
    from monkeystudy.analysis.measured_replay import REPLAY_INTEGRATOR
    from monkeystudy.plotting.page import render_page
    from monkeystudy.plotting.report import DRAWINGS

    html = render_page(tmp_path, {"replay": ds}, {}, drawings=DRAWINGS)
    assert "Gait:" not in html and "Integrator:" not in html
    assert "No step of this study runs the study&#x27;s gait" in html
    assert (f"integrated with {REPLAY_INTEGRATOR.method.upper()}, rtol "
            f"{REPLAY_INTEGRATOR.rtol:g}, atol {REPLAY_INTEGRATOR.atol:g}.") in html
