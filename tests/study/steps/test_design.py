"""The design step kind end to end: the smoke study through the command line, its dataset
contract, its fixed points and spectral radii, and the same numbers for one and two workers."""
from __future__ import annotations

import json
import threading
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

from monkeystudy.analysis.design import DesignSpace, evaluate_design
from monkeystudy.cli import app
from monkeystudy.controllers import Integrator
from monkeystudy.robot import Robot
from monkeystudy.study import load_study, run_study

from studyhelpers import assert_same_datasets, assert_written_as_declared
from test_motor_frame import design_b_study

ROOT = Path(__file__).resolve().parents[3]
SMOKE = ROOT / "studies" / "open_loop_design_smoke.yaml"

#: the names other tools read (docs/datasets.md), with units and dims
CONTRACT = {
    "spectral_radius": ("1", ("motor_start", "t_motor")),
    "spectral_radius_fd": ("1", ("motor_start", "t_motor")),
    "cycles_completed": ("1", ("replay",)),
    "error": ("rad2 + rad2 s-2", ("motor_start", "t_motor")),
    "rise": ("m", ("motor_start", "t_motor")),
}


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("design") / "out"
    result = CliRunner().invoke(app, ["run", str(SMOKE), "--out", str(out), "--workers", "2"])
    assert result.exit_code == 0, result.output
    with xr.open_dataset(out / "schedule.nc") as ds:
        return out, ds.load(), result.output


def test_the_smoke_study_writes_the_contract(smoke):
    out, ds, log = smoke
    assert "schedule: done" in log
    for v, (units, dims) in CONTRACT.items():
        assert ds[v].attrs["units"] == units, v
        assert ds[v].dims == dims, v
    for v in ds.variables:
        assert ds[v].attrs.get("units") is not None and ds[v].attrs.get("long_name"), v


def test_every_solved_design_is_a_fixed_point_whose_radius_agrees_with_fd(smoke):
    _, ds, _ = smoke
    ok = ds["status"].values == 0
    assert ok.sum() >= 6
    # the study's error measure, |P(z) - z|^2
    assert np.all(ds["error"].values[ok] < 1e-20)
    assert np.all(np.abs(ds["rise"].values[ok]) < 1e-10)
    rho, rho_fd = ds["spectral_radius"].values[ok], ds["spectral_radius_fd"].values[ok]
    assert np.all(np.abs(rho - rho_fd) < 1e-6)
    assert float(ds.attrs["spectral_radius_agreement"]) < 1e-6
    assert float(ds.attrs["best_error"]) < 1e-20


def test_the_best_design_is_checked_as_the_issue_asks(smoke):
    _, ds, _ = smoke
    rho = float(ds.attrs["best_spectral_radius"])
    # the smoke grid holds stable designs: the best must be one, and replays must show it
    assert rho < 1.0
    done = ds["cycles_completed"].values
    assert done[0] == ds.sizes["cycle"]           # exact timing: every cycle, within bound
    # walking on counts at least the cycles within the bound, at most the replay's length
    walked = ds["cycles_walked"].values
    assert np.all(walked >= done) and np.all(walked <= ds.sizes["cycle"])
    assert np.all(ds["refined_cycles_walked"].values >= ds["refined_cycles_completed"].values)
    # a perturbation decays at the leading multiplier's rate (fit over 20 cycles)
    assert abs(float(ds.attrs["decay_growth"]) - rho) < 0.02
    assert np.nanmax(ds["perturbation_distance"].values[-5:]) < 1e-3 * rho ** 10


def test_a_survival_step_runs_the_best_design(smoke):
    out, ds, log = smoke
    assert "schedule_survival: done" in log
    with xr.open_dataset(out / "schedule_survival.nc") as sv:
        assert sv.attrs["design_step"] == "schedule"
        assert sv.attrs["replay"] == "open_loop"
        # it starts from the best design's fixed point, with its own schedule
        assert float(sv.attrs["dtheta1"]) == float(ds.attrs["best_dtheta1"])
        assert float(sv.attrs["t_switch"]) == float(ds.attrs["best_t_switch"])
        assert sv["cycles_completed"].shape == (2, 8)
        assert np.all(sv["cycles_completed"].values >= 1)
        # a schedule-only design runs on the study's robot, and the dataset says so
        assert json.loads(sv.attrs["robot"])["name"] == "seed2009"


def test_runs_of_a_redesigned_robot_name_that_robot():
    """A survival dataset's ``robot`` is the robot its runs used: a design's own."""
    from monkeystudy.study.steps.gait_source import robot_attr

    base = Robot.preset("seed2009")
    space = DesignSpace(base)
    values = space.values({"t_switch": 0.47})
    same = robot_attr(base, space.robot_for(values), "as_built")
    assert same == base.to_dict()
    values["com"] = 0.45
    other = robot_attr(base, space.robot_for(values), "redesign")
    assert other["name"] == "redesign design (from seed2009)"
    assert other["link1"]["com"] == pytest.approx(0.45)
    assert other["link1"]["mass"] + other["link2"]["mass"] == pytest.approx(2.0)


def test_one_worker_equals_two(smoke, tmp_path):
    out, _, _ = smoke
    run_study(load_study(SMOKE), tmp_path / "one", workers=1)
    assert_same_datasets(out, tmp_path / "one")


def test_a_known_design_solves_to_the_same_gait_from_nearby_starts():
    """Newton from two different starts lands on one fixed point, and its multipliers by
    variational equations and finite differences agree to 1e-8."""
    space = DesignSpace(Robot.preset("seed2009"), base={"t_switch": 0.47}, balance="t_switch",
                        integrator=Integrator(rtol=1e-13, atol=1e-13))
    free = {"motor_start": -0.3, "t_motor": 0.18, "torque": -0.6354}
    a = evaluate_design(space, free, [-0.33, 4.75, 5.37], variational=True)
    b = evaluate_design(space, free, [-0.32, 4.76, 5.36], variational=True)
    assert a.ok and b.ok
    assert np.allclose(a.z, b.z, rtol=0, atol=1e-9)
    assert a.error < 1e-20 and abs(a.rise) < 1e-12
    assert np.max(np.abs(a.jacobian - a.jacobian_fd)) < 1e-7
    assert abs(a.spectral_radius - a.spectral_radius_fd) < 1e-8
    assert a.spectral_radius < 1.0


def test_designs_that_cannot_be_built_are_refused_without_simulating():
    space = DesignSpace(Robot.preset("seed2009"), base={"t_switch": 0.43})
    # all of a link's mass at its two ends gives at most m c (L - c)
    r = evaluate_design(space, {"com": 0.55, "inertia": 0.04}, [0.0, 1.5, 10.2])
    assert r.status == 4 and "no mass distribution" in r.message and r.nfev == 0
    r = evaluate_design(space, {"motor_start": -0.45}, [0.0, 1.5, 10.2])
    assert r.status == 4 and "before the vertical" in r.message


# --- the running clock ----------------------------------------------------------------------------
def test_the_running_clock_step_measures_the_same_gaits_stroboscopically(smoke):
    """``clock: run_on`` solves the same gaits as the restarting clock (the same orbit, its
    vertical crossing at clock phase zero) and measures the four multipliers of the
    stroboscopic map, both ways."""
    out, ds, log = smoke
    assert "schedule_clock: done" in log
    with xr.open_dataset(out / "schedule_clock.nc") as clk:
        clk = clk.load()
    assert clk.attrs["clock"] == "run_on" and ds.attrs["clock"] == "reset_at_vertical"
    assert clk.sizes["k"] == 4 and clk.sizes["row"] == 4 and ds.sizes["k"] == 3
    ok = clk["status"].values == 0
    assert ok.sum() >= 6
    assert np.array_equal(ok, ds["status"].values == 0)
    for v in ("theta2", "dtheta1", "dtheta2", "balance_value"):
        assert np.allclose(clk[v].values[ok], ds[v].values[ok], rtol=0, atol=1e-9), v
    # the same orbit is a fixed point of the running clock's map
    assert np.all(clk["error"].values[ok] < 1e-20)
    rho, rho_fd = clk["spectral_radius"].values[ok], clk["spectral_radius_fd"].values[ok]
    assert np.all(np.abs(rho - rho_fd) < 1e-6)
    assert clk["best_jacobian"].shape == (4, 4)
    assert np.max(np.abs(clk["best_jacobian"].values - clk["best_jacobian_fd"].values)) < 1e-6
    # the decay of a perturbation follows the leading multiplier of the 4-state map
    assert abs(float(clk.attrs["decay_growth"]) - float(clk.attrs["best_spectral_radius"])) \
        < 0.02


def test_a_running_clock_design_against_its_restarting_twin():
    """One design both ways: the same fixed point; the running clock's map has four
    multipliers (variational = finite differences), and a run from the fixed point stays
    on it with exact timing."""
    from monkeystudy.analysis.design import replay_design

    kw = dict(base={"t_switch": 0.47}, integrator=Integrator(rtol=1e-13, atol=1e-13))
    free = {"motor_start": -0.3, "t_motor": 0.18, "torque": -0.6354}
    reset = evaluate_design(DesignSpace(Robot.preset("seed2009"), **kw), free,
                            [-0.33, 4.75, 5.37], variational=True)
    space = DesignSpace(Robot.preset("seed2009"), clock="run_on", **kw)
    clk = evaluate_design(space, free, [-0.33, 4.75, 5.37], variational=True)
    assert reset.ok and clk.ok
    assert np.array_equal(clk.z, reset.z) and clk.period == reset.period
    assert clk.state.shape == (4,) and clk.state[0] == 0.0
    assert clk.error < 1e-20
    assert clk.jacobian.shape == (4, 4) and reset.jacobian.shape == (3, 3)
    assert np.max(np.abs(clk.jacobian - clk.jacobian_fd)) < 1e-7
    assert abs(clk.spectral_radius - clk.spectral_radius_fd) < 1e-8
    rep = replay_design(space, clk, cycles=10)
    assert rep.cycles_completed == 10 and np.all(rep.error < 1e-18)


def test_a_running_clock_needs_mirror_links_and_survival_refuses_it(tmp_path):
    text = SMOKE.read_text()
    bad = text.replace("clock: run_on}", "clock: run_on, fixed: {torque: -0.6354, "
                       "mass_ratio: 1.2}}")
    assert bad != text
    path = tmp_path / "bad.yaml"
    path.write_text(bad)
    result = CliRunner().invoke(app, ["validate", str(path)])
    assert result.exit_code == 2 and "mirror-image links" in result.output
    path.write_text(text.replace("from: schedule\n", "from: schedule_clock\n"))
    result = CliRunner().invoke(app, ["validate", str(path)])
    assert result.exit_code == 2, result.output
    # file, line and key of the survival step's from
    assert f"{path}:27: steps[3].from: design step 'schedule_clock' runs its clock on" \
        in result.output, result.output


def test_newton_gives_up_a_start_that_stalls():
    """A design with no gait near the start: |F| stops shrinking, and Newton stops before
    its iteration limit (each further step would cost a full stencil of runs)."""
    space = DesignSpace(Robot.preset("seed2009"), base={"t_switch": 0.4334, "motor_start": -0.3},
                        integrator=Integrator(rtol=1e-13, atol=1e-13))
    r = evaluate_design(space, {"com": 0.30, "inertia": 0.005, "t_motor": 0.1, "torque": -2.0},
                        [0.0, 1.4952, 10.2468])
    assert r.status == 3 and "not_converged" in r.message
    assert 4 <= r.iterations < space.max_iter


def test_the_verdict_tells_a_tick_replay_that_walks_on_from_one_that_falls():
    from monkeystudy.analysis.design import Replay
    from monkeystudy.kernel.layout import ST_FELL, ST_OK
    from monkeystudy.study.steps.design import walked_on

    # on the tick the orbit moves: the error leaves 1e-2 at once, then settles near 2.4e-3
    settles = np.r_[0.0134, 0.0219, 0.014, 0.0082, 0.004, np.full(95, 2.4e-3)]
    kept = Replay(0.001, settles, np.ones(100), np.zeros(100), 0, ST_OK, 100)
    said = walked_on(kept, 100)
    assert "walks on to 100 cycles without falling" in said
    assert "0.022 at most" in said and "0.0024 over the last 10" in said
    fell = Replay(0.001, settles[:7], np.ones(7), np.zeros(7), 0, ST_FELL, 7)
    assert walked_on(fell, 100) == ""
    short = Replay(0.001, settles[:50], np.ones(50), np.zeros(50), 0, ST_OK, 50)
    assert walked_on(short, 100) == ""
    stalls = Replay(0.001, settles, np.ones(100), np.zeros(100), 0, ST_OK, 60)
    assert walked_on(stalls, 100) == ""
    assert walked_on(short, 100) == ""


# --- a sequence gait's segments --------------------------------------------------------------------
SEGMENTS = design_b_study("segment_design") + """\
  - {name: design_survival, kind: survival, from: design, controller: {tick: 0.001},
     runs: 4, max_cycles: 10, seed: 30, min_advance: 0.5761}
"""


@pytest.fixture(scope="module")
def segments(tmp_path_factory):
    folder = tmp_path_factory.mktemp("segment_design")
    path = folder / "segments.yaml"
    path.write_text(SEGMENTS)
    run_study(load_study(path), folder / "out", workers=2)
    with xr.open_dataset(folder / "out" / "design.nc") as ds:
        return folder / "out", ds.load()


def test_a_segment_design_writes_the_full_maps_radius_in_the_motor_frame(segments):
    """The design dataset of a sequence gait in the motor frame: its axes are the segments'
    torques [N m] as the study writes them, the grid and the best design carry the full
    map's spectral radius (four multipliers, attribute height_in_map = 1) by variational
    equations and finite differences agreeing to 1e-6, every design holds its height, and
    the best cycle's torque is stated in the motor frame (the study's signs: + before the
    catch, - after it)."""
    out, ds = segments
    assert ds.attrs["torque_frame"] == "motor" and ds.attrs["height_in_map"] == 1
    assert ds["status"].dims == ("segment2_torque", "segment3_torque")
    assert ds["segment2_torque"].attrs["units"] == "N m"
    assert "motor frame" in ds["segment2_torque"].attrs["long_name"]
    assert "full map" in ds["spectral_radius"].attrs["long_name"]
    assert ds.sizes["k"] == 4 and ds["best_jacobian"].shape == (4, 4)
    ok = ds["status"].values == 0
    assert ok.all()
    rho, rho_fd = ds["spectral_radius"].values, ds["spectral_radius_fd"].values
    assert np.max(np.abs(rho - rho_fd)) < 1e-6 and np.all(rho < 1.0)
    assert np.max(np.abs(ds["rise"].values)) < 1e-12
    assert abs(ds.attrs["best_spectral_radius"] - ds.attrs["best_spectral_radius_fd"]) < 1e-6
    assert ds.attrs["best_segment2_torque"] > 0 > ds.attrs["best_segment3_torque"]
    torque, end = ds["motor_torque"].values, ds["attached_end"].values
    on = torque != 0.0
    assert np.all(torque[on & (end == 0)] > 0) and np.all(torque[on & (end == 1)] < 0)
    np.testing.assert_allclose(np.unique(torque[on & (end == 0)]),
                               [ds.attrs["best_segment2_torque"]], rtol=0, atol=1e-15)
    assert "t_switch" not in ds.attrs and "best_t_switch" not in ds.attrs


def test_a_survival_step_runs_the_segment_designs_best_gait(segments):
    out, ds = segments
    with xr.open_dataset(out / "design_survival.nc") as sv:
        assert sv.attrs["design_step"] == "design"
        assert sv.attrs["design_spectral_radius"] == ds.attrs["best_spectral_radius"]
        np.testing.assert_allclose([sv.attrs["dtheta1"], sv.attrs["dtheta2"]],
                                   [ds.attrs["best_dtheta1"], ds.attrs["best_dtheta2"]])
        assert sv["cycles_completed"].shape == (1, 4)


@pytest.mark.parametrize("edit, where, says", [
    ("segment3_torque: {start: -0.42, stop: -0.38", "steps[2].parameters",
     "'torque' is a horizontal gait's schedule parameter"),
    ("segment2_torque: {start: 0.30, stop: 0.34", "steps[2].parameters",
     "k from 1 to 3"),
    ("segment2_torque: {start: 0.30, stop: 0.34", "steps[2].parameters",
     "outside [-2.0, 2.0]"),
    ("    refine: {starts: 1", "steps[2].balance", "has no balance"),
])
def test_a_segment_design_refuses_what_its_gait_does_not_have(tmp_path, edit, where, says):
    """File, line and key of a parameter the gait does not have, one out of bounds, a
    balance."""
    replacement = {
        "'torque' is a horizontal gait's schedule parameter":
            "torque: {start: -0.42, stop: -0.38",
        "k from 1 to 3": "segment4_torque: {start: 0.30, stop: 0.34",
        "outside [-2.0, 2.0]": "segment2_torque: {start: 0.30, stop: 2.5",
        "has no balance": "    balance: torque\n    refine: {starts: 1",
    }[says]
    path = tmp_path / "bad.yaml"
    path.write_text(SEGMENTS.replace(edit, replacement))
    result = CliRunner().invoke(app, ["validate", str(path)])
    assert result.exit_code == 2, result.output
    assert f"{where}: " in result.output and says in result.output, result.output
    assert str(path) in result.output


def test_a_horizontal_design_refuses_segments_and_the_height():
    """The horizontal gait's design parameters are its schedule's; its schedules sense no
    height."""
    from monkeystudy.study.loader import StudyError, parse_study

    text = SMOKE.read_text()
    for bad, says in ((text.replace("motor_start: {", "segment1_torque: {", 1),
                       "'segment1_torque' is a sequence gait's segment"),
                      (text.replace("    kind: design\n", "    kind: design\n"
                                    "    height_in_map: true\n", 1), "sense no height")):
        assert bad != text
        with pytest.raises(StudyError, match=says):
            parse_study(bad, "bad.yaml")


def design_layout(path: Path):
    """``(name_of, dims_of)`` of a design dataset for ``assert_written_as_declared``: its
    free parameters' coordinates and ``refined_<parameter>`` are each one declaration, and the
    grid variables run over every free parameter."""
    with xr.open_dataset(path) as ds:
        params = [str(p) for p in json.loads(ds.attrs["parameters"])]

    def name_of(name):
        if name in params:
            return "<parameter>"
        for prefix in ("refined_", "screen_"):
            if name.startswith(prefix) and name[len(prefix):] in params:
                return f"{prefix}<parameter>"
        return name

    def dims_of(name, dims):
        out = []
        for d in dims:
            out += params if d == "<parameters>" else [name] if d == "<parameter>" else [d]
        return tuple(out)

    return name_of, dims_of


@pytest.mark.parametrize("dataset", ["schedule.nc", "schedule_clock.nc"])
def test_the_smoke_datasets_are_written_as_declared(smoke, dataset):
    out, _, _ = smoke
    name_of, dims_of = design_layout(out / dataset)
    assert_written_as_declared(out / dataset, "design", dims_of=dims_of, name_of=name_of)


def test_a_segment_design_is_written_as_declared(segments):
    out, _ = segments
    name_of, dims_of = design_layout(out / "design.nc")
    assert_written_as_declared(out / "design.nc", "design", dims_of=dims_of, name_of=name_of)


def test_a_screen_checks_the_candidate_that_lasts(segments):
    """The screen's candidates run under the same noise draws: the first is the one most of
    whose runs completed (then the most cycles), it is the design checked and handed on, and
    the candidates are the least-objective designs in the order of their rank."""
    out, ds = segments
    assert ds.attrs["chosen_by"] == "survival"
    survived, mean = ds["screen_survived"].values, ds["screen_mean_cycles"].values
    key = list(zip(-survived, -mean, ds["screen_rank"].values))
    assert key == sorted(key)
    assert sorted(ds["screen_rank"].values) == list(range(ds.sizes["candidate"]))
    assert ds.attrs["best_screen_survived"] == survived[0]
    for n in ("segment2_torque", "segment3_torque"):
        assert ds[f"screen_{n}"].values[0] == ds.attrs[f"best_{n}"]
    # by rank, the objectives do not decrease
    by_rank = ds["screen_objective"].values[np.argsort(ds["screen_rank"].values)]
    assert np.all(np.diff(by_rank) >= 0)
    assert (out / "design.nc").exists()


@pytest.mark.parametrize("edit, says", [
    ("noise: {timing: 1.0e-3,", "one noise level"),
    ("screen: {candidates: 3,", "clock reset_at_vertical"),
])
def test_a_screen_refuses_levels_and_a_running_clock(tmp_path, edit, says):
    text = {"one noise level": SEGMENTS.replace(edit, "noise: {timing: [1.0e-3, 2.0e-3],"),
            "clock reset_at_vertical": SMOKE.read_text().replace(
                "clock: run_on}", "clock: run_on, screen: {candidates: 2}}")}[says]
    from monkeystudy.study.loader import StudyError, parse_study

    with pytest.raises(StudyError, match=says):
        parse_study(text, "bad.yaml")


# --- a candidate must be a gait of the starting gait's kind --------------------------------------
#: design B's gait with the pulse after the catch at -2 N m for 0.1 s (a step) or 0.364 s (link
#: 2 spins through link 1, and with the full map's rho 0.99 it is the grid's least objective)
SPINNING = SEGMENTS.split("  - name: design\n")[0] + """\
  - name: design
    kind: design
    from: floquet
    parameters:
      segment3_torque: {start: -2.0, stop: -2.0, num: 1}
      segment3_value: {start: 0.1, stop: 0.36363636363636365, num: 2}
    refine: {starts: 0}
    verify: {cycles: 10, decay_cycles: 5, basin_num: 3, basin_cycles: 5}
  - {name: design_survival, kind: survival, from: design, controller: {tick: 0.001},
     runs: 2, max_cycles: 5, seed: 30, min_advance: 0.5}
"""


def test_a_design_that_is_no_step_is_refused_and_the_best_step_handed_on(tmp_path):
    path = tmp_path / "spinning.yaml"
    path.write_text(SPINNING)
    run_study(load_study(path), tmp_path / "out", workers=1)
    with xr.open_dataset(tmp_path / "out" / "design.nc") as ds:
        ds.load()
    rho = ds["spectral_radius_fd"].values[0]
    assert ds["status"].values.tolist() == [[0, 0]] and rho[1] < 1.0 < rho[0]
    # the grid's least objective spins link 2: refused, with the reason
    refused = json.loads(ds.attrs["refused_candidates"])
    assert [r["design"]["segment3_value"] for r in refused] == [0.36363636363636365]
    assert refused[0]["source"] == "grid"
    assert "link 2 turns through link 1" in refused[0]["why"]
    # the step checked and handed on is the one that swings
    assert ds.attrs["best_segment3_value"] == 0.1
    assert ds.attrs["best_spectral_radius_fd"] == rho[0]
    assert abs(ds.attrs["best_theta2"]) < np.pi and ds.attrs["best_advance"] > 1.0
    with xr.open_dataset(tmp_path / "out" / "design_survival.nc") as sv:
        assert sv.attrs["dtheta1"] == ds.attrs["best_dtheta1"]


def test_a_design_step_with_no_step_among_its_candidates_hands_on_nothing(tmp_path):
    from monkeystudy.study.errors import RunFailed

    path = tmp_path / "spinning.yaml"
    path.write_text(SPINNING.replace("segment3_value: {start: 0.1, stop: 0.36363636363636365, "
                                     "num: 2}", "segment3_value: {start: 0.36363636363636365, "
                                     "stop: 0.36363636363636365, num: 1}"))
    with pytest.raises(RunFailed, match="no candidate design is a gait of the starting "
                                        "gait's kind, nothing to hand on: grid design"):
        run_study(load_study(path), tmp_path / "out", workers=1)
    assert not (tmp_path / "out" / "design.nc").exists()
    assert not (tmp_path / "out" / "design_survival.nc").exists()


def test_a_design_step_counts_designs_then_each_phase_and_survival_counts_runs(tmp_path):
    """The design step's line counts its designs, then each of its phases in the driver
    (refine, screen, checks) with its own count that reaches its total; a survival step
    counts its runs, not its blocks."""
    from monkeystudy.study.progress import Reporter

    class Recorder(Reporter):
        def __init__(self):
            self.events, self.lock = [], threading.Lock()

        def start(self, name, total, done=0, unit="blocks"):
            with self.lock:
                self.events.append(["start", name, "", total, unit, 0])

        def phase(self, name, label, total, unit, then="", done=0):
            with self.lock:
                self.events.append(["phase", name, label, total, unit, done])

        def advance(self, name, n=1):
            with self.lock:
                for e in reversed(self.events):      # into the step's latest count
                    if e[0] in ("start", "phase") and e[1] == name:
                        e[5] += n
                        break

        def estimate(self, name, label, seconds):
            with self.lock:
                self.events.append(["estimate", name, label, seconds, "", 0])

    path = tmp_path / "segments.yaml"
    path.write_text(SEGMENTS)
    rec = Recorder()
    run_study(load_study(path), tmp_path / "out", workers=1, reporter=rec)
    design = [(e[0], e[2], e[4]) for e in rec.events if e[1] == "design"
              and e[0] != "estimate"]
    assert design == [("start", "", "designs"), ("phase", "grid", "designs"),
                      ("phase", "refine", "designs"), ("phase", "screen", "runs"),
                      ("phase", "checks", "checks")]
    phases = {e[2]: e for e in rec.events if e[1] == "design" and e[0] == "phase"}
    assert phases["grid"][3] == 4                          # 2 x 2 designs
    assert phases["refine"][3] == 1 * (12 + 2)             # one start: 12 designs, 2 replays
    with xr.open_dataset(tmp_path / "out" / "design.nc") as ds:
        screened = ds.sizes["candidate"]                  # the candidates there were (<= 3)
    assert phases["screen"][3] == screened * 6            # 6 runs each
    for label, e in phases.items():
        assert e[5] == e[3], (label, e)                   # each count reaches its total
    # the step's eta: the checks estimated from each refined design's replays while the
    # refine runs (one start), the screen not (no sound estimate before it runs)
    at = {e[2]: i for i, e in enumerate(rec.events) if e[1] == "design" and e[0] == "phase"}
    estimates = [(i, e) for i, e in enumerate(rec.events) if e[0] == "estimate"]
    assert [(e[1], e[2]) for _, e in estimates] == [("design", "checks")]
    assert all(at["refine"] < i < at["screen"] and 0 < e[3] < 60 for i, e in estimates)
    survival = [e for e in rec.events if e[1] == "design_survival"]
    assert [(e[0], e[3], e[4], e[5]) for e in survival] == [("start", 4, "runs", 4)]
