"""The hardware_replay step kind: validation with file:line: key, an end-to-end run of
studies/acromonk_smoke.yaml, the dataset contract of docs/datasets.md (``hardware_replay``),
and the numbers held against :mod:`monkeystudy.analysis.measured_replay` called directly on
the same inputs."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from monkeystudy.analysis.measured_replay import (
    ModelValues, errors_of, identify, model_swings, whole_swing_error,
)
from monkeystudy.measured import SHIPPED_LOGS, read_log, sensor_floor
from monkeystudy.robot import Friction
from monkeystudy.study import StudyError, load_study, parse_study, run_study
from monkeystudy.study.steps import REGISTRY
from monkeystudy.study.steps.hardware_replay import HardwareReplayStep

from studyhelpers import RecordingReporter, assert_written_as_declared, open_dataset

ROOT = Path(__file__).resolve().parents[3]
SMOKE = ROOT / "studies" / "acromonk_smoke.yaml"
FULL = ROOT / "studies" / "acromonk.yaml"
URDF = ROOT / "data" / "acromonk" / "model" / "acromonk.urdf"
LOGS = ROOT / "data" / "acromonk" / "logs"

ROBOT = f"""\
robot:
  urdf: {URDF}
  links: [hook_1, link_2]
  joints: [virtul_joint_hook_1, joint_1]
  far_grip: hook_2
"""
#: a study whose step starts on line 10
BASE = """\
schema_version: 1
name: v
{robot}{gait}steps:
  - name: hw
    kind: hardware_replay
    train: [{train}]
    held_out: [{held}]
{body}"""


GAIT = "gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}\n"


def text(body: str = "", *, train: str = f"{LOGS}/BF_pd_5x.csv.gz",
         held: str = f"{LOGS}/ZB_pd_1x.csv.gz", robot: str = ROBOT, gait: str = GAIT) -> str:
    return BASE.format(robot=robot, train=train, held=held, body=body, gait=gait)


def refused(study_text: str) -> list[str]:
    with pytest.raises(StudyError) as exc:
        parse_study(study_text, "s.yaml")
    return str(exc.value).splitlines()


# --- settings ----------------------------------------------------------------------------------
def test_defaults_are_the_documented_ones():
    st = parse_study(text()).study.step("hw")
    assert isinstance(st, HardwareReplayStep)
    assert st.horizons == [0.1, 0.2, 0.5] and st.start_every == 0.1
    assert st.identify.parameters == ["pivot_viscous", "pivot_coulomb", "joint_viscous",
                                      "joint_coulomb"]
    assert (st.identify.window, st.identify.every, st.identify.max_evaluations) == (0.3, 0.1,
                                                                                    60)
    # AcroMonk's MuJoCo model: damping 0.044 at the hook's joint, 0.06 at the elbow
    assert st.published_values() == ModelValues(Friction(0.044), Friction(0.06))
    assert st.log_files() == {"BF_pd_5x": str(LOGS / "BF_pd_5x.csv.gz"),
                              "ZB_pd_1x": str(LOGS / "ZB_pd_1x.csv.gz")}
    # the identification, then each fixed model on each log
    assert REGISTRY["hardware_replay"].n_tasks(st, "horizontal") == 1 + 2 * 2


def test_logs_are_relative_to_the_study_file(tmp_path):
    folder = tmp_path / "studies"
    folder.mkdir()
    study = folder / "s.yaml"
    study.write_text(text(train="../logs/BF_pd_5x.csv.gz", held="../logs/ZB_pd_1x.csv.gz"))
    (tmp_path / "logs").symlink_to(LOGS)
    st = load_study(study).study.step("hw")
    assert st.log_files()["BF_pd_5x"] == str((tmp_path / "logs" / "BF_pd_5x.csv.gz")
                                             .resolve())


def test_the_step_is_keyed_on_its_logs_contents(tmp_path):
    # a dataset is current only while the logs it was made from are unchanged: an edited log
    # (same name, same path) changes the step's key
    import gzip
    import shutil

    from monkeystudy.study.plan import step_keys

    logs = tmp_path / "logs"
    logs.mkdir()
    for name in ("BF_pd_5x", "ZB_pd_1x"):
        shutil.copy(LOGS / f"{name}.csv.gz", logs / f"{name}.csv.gz")
    study = tmp_path / "s.yaml"
    study.write_text(text(train=f"{logs}/BF_pd_5x.csv.gz", held=f"{logs}/ZB_pd_1x.csv.gz"))
    before = step_keys(load_study(study).study)["hw"]
    assert step_keys(load_study(study).study)["hw"] == before
    held = logs / "ZB_pd_1x.csv.gz"
    with gzip.open(held, "rt") as f:
        rows = f.read().splitlines(keepends=True)
    # one measured value changed in its last digit
    row = rows[-1].split(",")
    row[2] = row[2][:-1] + ("1" if row[2][-1] != "1" else "2")
    rows[-1] = ",".join(row)
    with gzip.open(held, "wt") as f:
        f.writelines(rows)
    assert step_keys(load_study(study).study)["hw"] != before


BAD = [
    # (study text, expected "s.yaml:line: key: message" start)
    (text(robot="robot: seed2009\n"),
     "s.yaml:3: robot: a hardware_replay step replays a robot read from its URDF"),
    (text(train=f"{LOGS}/nope.csv.gz"), "s.yaml:12: steps[0].train[0]: no such file: "),
    (text(held=str(URDF)), f"s.yaml:13: steps[0].held_out[0]: {URDF}:1: "),
    (text(train=f"{LOGS}/ZB_pd_1x.csv.gz", held=f"{LOGS}/FB_pd_1x_.csv.gz"),
     "s.yaml:12: steps[0].train: no log has a state_machine_flag column"),
    (text(held=f"{LOGS}/BF_pd_5x.csv.gz"),
     "s.yaml:13: steps[0].held_out[0]: 'BF_pd_5x' is also the name of "),
    (text(held=""), "s.yaml:13: steps[0].held_out: must not be empty"),
    (text("    horizons: [0.2, 0.1]\n"), "s.yaml:14: steps[0].horizons: must be increasing"),
    (text("    horizons: [0.0]\n"), "s.yaml:14: steps[0].horizons[0]: must be > 0"),
    (text("    start_every: 0\n"), "s.yaml:14: steps[0].start_every: must be > 0"),
    (text("    identify: {parameters: [friction]}\n"),
     "s.yaml:14: steps[0].identify.parameters[0]: must be "),
    (text("    identify: {parameters: [torque_scale, torque_scale]}\n"),
     "s.yaml:14: steps[0].identify.parameters: parameters must be distinct"),
    (text("    published: {pivot: {viscous: -0.1}}\n"),
     "s.yaml:14: steps[0].published.pivot.viscous: must be >= 0"),
]


@pytest.mark.parametrize("study_text, expected", BAD)
def test_bad_settings_are_refused_at_their_line(study_text, expected):
    lines = refused(study_text)
    assert any(line.startswith(expected) for line in lines), lines


def test_a_study_of_hardware_replay_steps_alone_needs_no_gait():
    # the logs' measured torque drives the robot: the study names no gait, and its spec, step
    # key and dataset attributes hold none (the attributes have no gait, not a dummy one)
    from monkeystudy.study.plan import step_keys
    from monkeystudy.study.runner import step_attrs
    from monkeystudy.study.spec import gait_spec

    loaded = parse_study(text(gait=""), "s.yaml")
    study = loaded.study
    assert study.gait is None
    spec = gait_spec(study)
    assert not spec.has_gait and spec.sequence is None and spec.robot == study.to_robot()
    with_gait = parse_study(text(), "s.yaml").study
    assert step_keys(study)["hw"] != step_keys(with_gait)["hw"]
    attrs = step_attrs(loaded, study.step("hw"), "history")
    assert "gait" not in attrs and attrs["robot"] == study.to_robot().to_dict()
    assert REGISTRY["hardware_replay"].runs_gait is False


def test_a_study_without_a_gait_is_refused_when_a_step_runs_one():
    lines = refused(text("  - {name: g, kind: refine, start: [0.9, 10.9]}\n", gait=""))
    assert lines == ["s.yaml:1: gait: required key missing: step 'g' (refine) runs the "
                     "study's gait (only hardware_replay, atlas or route steps run none)"], lines


def test_shipped_studies():
    # the step runs no gait: the shipped studies name none
    assert load_study(FULL).study.gait is None and load_study(SMOKE).study.gait is None
    full = load_study(FULL).study.step("replay")
    assert list(full.log_files()) == ["BF_tvlqr_5x", "BF_pd_5x", "BF_rl_5x", "BF_tvlqr_1x",
                                      "FB_pd_1x_", "ZB_pd_1x", "ZB_tvlqr_1x", "ZF_pd_1x",
                                      "ZF_tvlqr_1x"]
    assert full.train_names() == ["BF_tvlqr_5x", "BF_pd_5x"]
    assert full.horizons == [0.1, 0.2, 0.5]
    smoke = load_study(SMOKE).study.step("replay")
    assert smoke.train_names() == ["BF_pd_5x"] and smoke.horizons == [0.1, 0.2]
    # the study and tools/acromonk_replay.py (acromonk_robot) state one servo geometry
    from monkeystudy.analysis.measured_replay import ACROMONK_ROTOR, acromonk_robot
    assert load_study(FULL).study.to_robot() == acromonk_robot()
    assert acromonk_robot().rotor == ACROMONK_ROTOR


# --- the smoke run -----------------------------------------------------------------------------
@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    """studies/acromonk_smoke.yaml run on 2 workers: (the study's step, its dataset)."""
    out = tmp_path_factory.mktemp("acromonk_smoke")
    loaded = load_study(SMOKE)
    run_study(loaded, out, workers=2)
    return loaded.study.step("replay"), out


def test_the_dataset_is_written_as_declared(smoke):
    assert_written_as_declared(smoke[1] / "replay.nc", "hardware_replay")


def test_the_dataset_states_the_replays_integrator_and_no_gait(smoke):
    from monkeystudy.analysis.measured_replay import REPLAY_INTEGRATOR

    attrs = open_dataset(smoke[1], "replay.nc").attrs
    assert "gait" not in attrs
    assert attrs["replay_integrator"] == (f"{REPLAY_INTEGRATOR.method} rtol "
                                          f"{REPLAY_INTEGRATOR.rtol:g} atol "
                                          f"{REPLAY_INTEGRATOR.atol:g}")


def test_logs_and_swings_are_labelled(smoke):
    ds = open_dataset(smoke[1], "replay.nc")
    assert list(ds["log"].values) == ["BF_pd_5x", "ZB_pd_1x", "FB_pd_1x_"]
    assert list(ds["held_out"].values) == [0, 1, 1]
    assert list(ds["model"].values) == ["identified", "published_damping", "frictionless"]
    assert list(ds["joint"].values) == ["shoulder", "elbow"]
    assert list(ds["horizon"].values) == [0.1, 0.2]
    assert list(ds["log_swings"].values) == [5, 1, 1]
    assert list(ds["swing"].values) == [f"BF_pd_5x#{k}" for k in range(1, 6)] + \
        ["ZB_pd_1x#1", "FB_pd_1x_#1"]
    # the 5x log's hooks alternate (docs/acromonk.md, "Roles and signs after a catch")
    assert list(ds["swing_hook"].values[:5]) == ["motor_arm", "imu_arm"] * 2 + ["motor_arm"]
    assert int(ds.attrs["bit_reproducible"]) == 1


def test_identified_values_are_identifys_on_the_same_inputs(smoke):
    step, out = smoke
    ds = open_dataset(out, "replay.nc")
    base = load_study(SMOKE).study.to_robot()
    train = model_swings(read_log(SHIPPED_LOGS / "BF_pd_5x.csv.gz"))
    fit = identify(base, train, names=("pivot_viscous", "joint_viscous"), window=0.3,
                   every=0.3, max_nfev=20)
    assert list(ds["parameter"].values) == list(fit.names)
    np.testing.assert_array_equal(ds["identified_value"].values, fit.values)
    np.testing.assert_array_equal(ds["ci95_clustered"].values, fit.ci95)
    np.testing.assert_array_equal(ds["ci95_independent"].values, fit.ci95_iid)
    assert ds.attrs["fit_windows"] == fit.windows and ds.attrs["fit_swings"] == 5
    assert list(ds["parameter_units"].values) == ["N m s", "N m s"]
    mv = ds["model_value"].values
    np.testing.assert_array_equal(mv[0], fit.values)
    np.testing.assert_array_equal(mv[1], [0.044, 0.06])
    np.testing.assert_array_equal(mv[2], [0.0, 0.0])


def test_the_comparison_is_the_replays_errors(smoke):
    """A fixed model's RMS and median errors and start counts are ``errors_of``'s on the
    log's swings, and each is the statistic of the dataset's own per-start errors."""
    step, out = smoke
    ds = open_dataset(out, "replay.nc")
    base = load_study(SMOKE).study.to_robot()
    swings = model_swings(read_log(SHIPPED_LOGS / "FB_pd_1x_.csv.gz"))
    e = errors_of(ModelValues(Friction(0.044), Friction(0.06)), base, swings,
                  horizons=(0.1, 0.2), every=0.1)
    for k, h in enumerate((0.1, 0.2)):
        np.testing.assert_allclose(ds["rms_error"].values[1, 2, :, k], e.rms(h), rtol=1e-12)
        np.testing.assert_allclose(ds["median_abs_error"].values[1, 2, :, k],
                                   e.median_abs(h), rtol=1e-12)
        assert int(ds["start_count"].values[2, k]) == e.count(h)
    on_log = np.array([s.startswith("FB_pd_1x_#") for s in ds["start_swing"].values])
    for m in range(3):
        for k in range(2):
            err = ds["start_error"].values[m, on_log, :, k]
            err = err[np.isfinite(err[:, 0])]
            assert err.shape[0] == int(ds["start_count"].values[2, k])
            np.testing.assert_allclose(ds["rms_error"].values[m, 2, :, k],
                                       np.sqrt(np.mean(err ** 2, axis=0)), rtol=1e-12)
    # the whole-swing RMS is over the log's swings' own
    sw = ds["swing_rms"].values[:, :5]
    np.testing.assert_allclose(ds["whole_swing_rms"].values[:, 0],
                               np.sqrt(np.mean(sw ** 2, axis=1)), rtol=1e-12)


def test_the_series_are_the_identified_models_replay(smoke):
    """Each swing's series starts at its measured state, its measured samples are the
    swing's, and its error's RMS is swing_rms, whole_swing_error's; padding past the swing
    is NaN."""
    step, out = smoke
    ds = open_dataset(out, "replay.nc")
    n = ds["swing_samples"].values
    sim, meas = ds["simulated_angle"].values, ds["measured_angle"].values
    for i in range(ds.sizes["swing"]):
        np.testing.assert_array_equal(sim[i, 0], meas[i, 0])
        assert np.all(np.isfinite(sim[i, :n[i]])) and np.all(np.isnan(sim[i, n[i]:]))
        # over the samples after the first (whole_swing_error's)
        rms = np.sqrt(np.mean((sim[i, 1:n[i]] - meas[i, 1:n[i]]) ** 2, axis=0))
        np.testing.assert_allclose(rms, ds["swing_rms"].values[0, i], rtol=1e-12)
    ms = model_swings(read_log(SHIPPED_LOGS / "ZB_pd_1x.csv.gz"))[0]
    i = list(ds["swing"].values).index("ZB_pd_1x#1")
    assert n[i] == len(ms)
    np.testing.assert_array_equal(meas[i, :n[i]], ms.angles)
    np.testing.assert_array_equal(ds["measured_torque"].values[i, :n[i]], ms.torque)
    pivot, joint = ds["identified_value"].values      # pivot_viscous, joint_viscous
    fit = ModelValues(Friction(pivot), Friction(joint))
    np.testing.assert_allclose(ds["swing_rms"].values[0, i],
                               whole_swing_error(fit.robot(load_study(SMOKE).study.to_robot()),
                                                 ms), rtol=1e-12)


def test_the_sensor_floor_is_the_training_logs(smoke):
    ds = open_dataset(smoke[1], "replay.nc")
    f = sensor_floor(read_log(SHIPPED_LOGS / "BF_pd_5x.csv.gz"))
    h = np.array([0.1, 0.2])
    np.testing.assert_allclose(ds["sensor_floor"].values,
                               [f.shoulder_std + abs(f.offset_drift) * h, [f.elbow_std] * 2],
                               rtol=1e-12)


def test_the_identification_and_the_replays_after_it_count_as_they_go(tmp_path):
    """The least-squares identification (minutes on studies/acromonk.yaml) is no silent
    task at the end of the step's count: it counts its residual
    evaluations as it makes them (``replay: identify``, out of the most it can make:
    :func:`identify_evaluations`, said to be that) and the identified model's replays of the
    logs after it count the logs (``replay: replays``); each count reaches its total."""
    path = tmp_path / "tiny.yaml"
    path.write_text(text("    horizons: [0.1]\n"
                         "    identify: {parameters: [joint_viscous], every: 0.3, "
                         "max_evaluations: 3}\n",
                         gait=""))
    rec = RecordingReporter()
    run_study(load_study(path), tmp_path / "out", workers=1, reporter=rec)
    fit = [e for e in rec.events if e[1] == "hw: identify"]
    assert fit, [e for e in rec.events if e[1] == "hw"]   # the step's count of tasks alone
    from monkeystudy.analysis.measured_replay import identify_evaluations
    most = identify_evaluations(3, 1)
    assert fit[0] == ("start", "hw: identify", most, 0, "residual evaluations at most")
    assert fit[-1] == ("finish", "hw: identify")
    # counted as they come (a worker sends its count at most every 0.2 s), the rest of the
    # most when the fit is over
    counts = [e[2] for e in fit if e[0] == "advance"]
    assert all(n > 0 for n in counts) and sum(counts) == most, counts
    replays = [e for e in rec.events if e[1] == "hw: replays"]
    assert replays[0] == ("start", "hw: replays", 2, 0, "logs")
    assert sum(e[2] for e in replays if e[0] == "advance") == 2
    assert replays[-1] == ("finish", "hw: replays")
    assert rec.events.index(fit[-1]) < rec.events.index(replays[0])
    tasks = [e for e in rec.events if e[1] == "hw"]
    assert tasks[0] == ("start", "hw", 5, 0, "tasks")
    assert sum(e[2] for e in tasks if e[0] == "advance") == 5
