"""AcroMonk's hardware logs (monkeystudy.measured), on the shipped logs in data/acromonk/logs."""
from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest

from monkeystudy import measured
from monkeystudy.measured import (
    CATCH, ELBOW_ENCODER_STEP, IMU_ARM, MOTOR_ARM, RELEASE, SWING, LogError, closed_chain_shoulder,
    cut_agreement, elbow_grid_deviation, elbow_step, hand_overs, holding, log_paths, read_log,
    sampling, sensor_floor, swing_state, swings, swings_by_desired, swings_by_flag,
)

LOGS = Path(__file__).resolve().parents[1] / "data" / "acromonk" / "logs"
PATHS = log_paths(LOGS)
FLAGGED = ["BF_pd_5x", "BF_tvlqr_5x"]
TRAJECTORY_LAYOUT = {"FB_pd_1x_", "ZB_tvlqr_1x", "ZF_tvlqr_1x"}


def _log(name: str) -> measured.HardwareLog:
    return read_log(LOGS / f"{name}.csv.gz")


def _lines(path: Path) -> list[str]:
    with gzip.open(path, "rt") as fh:
        return fh.read().splitlines()


def test_the_nine_logs_are_found():
    assert len(PATHS) == 9


# --- reading ------------------------------------------------------------------------------------
@pytest.mark.parametrize("path", PATHS, ids=lambda p: p.name)
def test_a_log_reads_into_si_arrays(path):
    log = read_log(path)
    lines = _lines(path)
    assert len(log) == len(lines) - 1
    assert log.layout == ("trajectory" if log.name in TRAJECTORY_LAYOUT else "store")
    first_time = float(lines[1].split(",")[lines[0].split(",").index("meas_time")])
    assert log.time[0] == 0.0 and log.time_offset == first_time
    assert np.all(np.diff(log.time) >= 0)
    # angles in radians (not revolutions, not degrees): the elbow sweeps about +-2 rad
    for a in (log.shoulder_angle, log.elbow_angle):
        assert np.all(np.abs(a) <= np.pi)
    assert np.ptp(log.elbow_angle) > 1.5
    for a in (log.shoulder_rate, log.elbow_rate, log.elbow_torque):
        assert np.all(np.isfinite(a))
    # the servo's limits: |torque| stays within a few N m
    assert np.max(np.abs(log.elbow_torque)) < 6.0
    assert log.elbow_torque is log.columns["elbow_meas_tau"]
    assert set(log.columns) == set(lines[0].split(","))
    with pytest.raises(ValueError):
        log.elbow_angle[0] = 1.0                        # read-only
    assert (log.phase is not None) == (log.name in FLAGGED)


def test_desired_nan_only_outside_tracking_and_never_in_measured_columns():
    for name in FLAGGED:
        log = _log(name)
        desired = np.isfinite(log.columns["elbow_des_pos_store"])
        assert np.array_equal(desired, log.phase == SWING)
        assert np.all(np.isnan(log.columns["elbow_des_tau_store"]))   # never written


def test_a_plain_csv_reads_like_the_gzip(tmp_path):
    src = LOGS / "ZF_tvlqr_1x.csv.gz"
    plain = tmp_path / "ZF_tvlqr_1x.csv"
    plain.write_text("\n".join(_lines(src)) + "\n")
    a, b = read_log(src), read_log(plain)
    assert np.array_equal(a.elbow_angle, b.elbow_angle) and np.array_equal(a.time, b.time)


def _write(tmp_path, lines: list[str]) -> Path:
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    return path


def _with_field(row: str, index: int, text: str) -> str:
    fields = row.split(",")
    fields[index] = text
    return ",".join(fields)


@pytest.mark.parametrize("edit, message", [
    (lambda h, r: (["time,a,b"], r), ":1: header is not an AcroMonk log"),
    (lambda h, r: (h, r[:2] + [_with_field(r[2], 4, "abc")] + r[3:]),
     ":4: shoulder_meas_vel: not a number: 'abc'"),
    (lambda h, r: (h, r[:3] + [",".join(r[3].split(",")[:-1])] + r[4:]),
     ":5: 18 fields, the header has 19"),
    (lambda h, r: (h, r[:1] + [_with_field(r[1], 2, "nan")] + r[2:]),
     ":3: shoulder_meas_pos: nan"),
    (lambda h, r: (h, [r[0], r[2], r[1]] + r[3:]), ":4: meas_time:"),
])
def test_a_malformed_log_is_refused_naming_file_and_line(tmp_path, edit, message):
    lines = _lines(LOGS / "ZB_pd_1x.csv.gz")
    header, rows = edit([lines[0]], lines[1:])
    path = _write(tmp_path, header + rows)
    with pytest.raises(LogError) as err:
        read_log(path)
    assert str(err.value).startswith(str(path) + ":")
    assert message in str(err.value)


def test_an_unknown_flag_is_refused(tmp_path):
    lines = _lines(LOGS / "BF_pd_5x.csv.gz")
    row = lines[10].split(",")
    row[-1] = "3.0"
    path = _write(tmp_path, lines[:10] + [",".join(row)] + lines[11:])
    with pytest.raises(LogError, match=r"bad\.csv:11: state_machine_flag: 3\.0"):
        read_log(path)


def test_a_missing_file_is_refused(tmp_path):
    with pytest.raises(LogError, match="nope.csv: cannot read"):
        read_log(tmp_path / "nope.csv")


# --- sampling ------------------------------------------------------------------------------------
@pytest.mark.parametrize("path", PATHS, ids=lambda p: p.name)
def test_sampling_statistics(path):
    log = read_log(path)
    s = sampling(log)
    lines = _lines(path)
    k = lines[0].split(",").index("meas_time")
    dt = np.diff([float(line.split(",")[k]) for line in lines[1:]])
    assert s.median == pytest.approx(np.median(dt), rel=1e-9)
    assert s.max == pytest.approx(dt.max(), rel=1e-9)
    assert s.min <= s.median <= s.p95 <= s.max
    assert 50.0 < s.median_rate < 500.0                 # 70-450 Hz as the logs go
    assert s.max < 0.25                                  # the longest gap: the 0.2 s pauses
    assert s.zero == int(np.sum(dt == 0))


def test_the_long_gaps_are_the_pauses_between_brachiations():
    """The 0.2 s gaps of the 5x logs fall between a catch and the next release."""
    log = _log("BF_tvlqr_5x")
    dt = np.diff(log.time)
    big = np.flatnonzero(dt > 0.1)
    assert big.size == 4
    assert np.all(log.phase[big] == CATCH) and np.all(log.phase[big + 1] == RELEASE)


# --- swings -------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", FLAGGED)
def test_swings_by_flag(name):
    log = _log(name)
    sws = swings_by_flag(log)
    runs = np.sum(np.diff(np.r_[0, (log.phase == SWING).astype(int)]) == 1)
    assert len(sws) == runs == 5
    for s in sws:
        assert np.all(log.phase[s.rows] == SWING)
        assert log.phase[s.start - 1] == RELEASE and log.phase[s.stop] == CATCH
        # the BF trajectory lasts 1.91 s (data/acromonk/trajectories/BF)
        assert 1.85 < log.time[s.stop] - log.time[s.start] < 2.0
    for a, b in zip(sws, sws[1:]):
        assert a.stop < b.start                         # ordered, apart
    # the swing ends with the hook at the next bar: both hooks at one height
    for s in sws:
        st = swing_state(log, s)
        assert abs(np.cos(st.q1[-1]) + np.cos(st.q1[-1] + st.q2[-1])) < 0.1


@pytest.mark.parametrize("name", FLAGGED)
def test_the_desired_rule_cuts_where_the_flag_does(name):
    log = _log(name)
    d = cut_agreement(log)
    assert d.shape == (5, 2)
    assert np.all(d == 0.0)


def test_the_desired_rule_can_disagree():
    """A log whose desired columns were blanked for the catch's first rows disagrees."""
    log = _log("BF_pd_5x")
    cols = dict(log.columns)
    des = cols["elbow_des_pos_store"].copy()
    first = swings_by_flag(log)[0]
    des[first.stop - 3:first.stop] = np.nan
    cols["elbow_des_pos_store"] = des
    changed = measured.HardwareLog(**{**log.__dict__, "columns": cols})
    assert cut_agreement(changed)[0, 1] < 0


@pytest.mark.parametrize("name, count", [("BF_rl_5x", 5), ("BF_tvlqr_1x", 1), ("ZB_pd_1x", 1),
                                         ("ZF_pd_1x", 1), ("FB_pd_1x_", 1), ("ZB_tvlqr_1x", 1),
                                         ("ZF_tvlqr_1x", 1)])
def test_swings_of_logs_without_the_flag(name, count):
    log = _log(name)
    sws = swings(log)
    assert len(sws) == count and all(s.rule == "desired" for s in sws)
    for a, b in zip(sws, sws[1:]):
        assert a.stop < b.start


def test_the_front_release_is_left_out():
    """FB_pd_1x_ starts with the front release (the torque schedule -3.5, -2.5, then +3 N m,
    no trajectory: des_time 0): its swing starts on the trajectory's first point."""
    log = _log("FB_pd_1x_")
    s = swings_by_desired(log)[0]
    release = log.columns["elbow_des_tau"][:s.start]
    assert set(np.unique(release)) == {-3.5, -2.5, 3.0}
    assert log.columns["des_time"][s.start] == 0.0 and log.columns["des_time"][s.start + 1] > 0
    assert log.columns["elbow_des_pos"][s.start] != 0.0


# --- roles and signs -----------------------------------------------------------------------------
@pytest.mark.parametrize("name", [*FLAGGED, "BF_rl_5x"])
def test_the_hooks_alternate_and_the_imu_formula_says_which(name):
    log = _log(name)
    held = [holding(log, s) for s in swings(log)]
    assert [h.hook for h in held] == [MOTOR_ARM, IMU_ARM, MOTOR_ARM, IMU_ARM, MOTOR_ARM]
    for h in held:
        chosen, other = (h.imu_swings, h.imu_holds) if h.hook == MOTOR_ARM \
            else (h.imu_holds, h.imu_swings)
        assert chosen < 1e-9 < 1.0 < other and not h.assumed


@pytest.mark.parametrize("name", [*FLAGGED, "BF_rl_5x"])
def test_the_lab_state_repeats_from_swing_to_swing(name):
    """In the lab's convention every BF swing tracks one trajectory: q2 and the torque of a
    swing from the IMU arm match the first swing's (correlation > 0.85); in the motor's frame
    they would be mirrored (correlation < -0.85)."""
    log = _log(name)
    states = [swing_state(log, s) for s in swings(log)]
    grid = np.linspace(0.0, 1.85, 200)

    def on_grid(st, values):
        return np.interp(grid, st.time, values)

    ref = states[0]
    for st in states[1:]:
        s = 1 if st.hook == MOTOR_ARM else -1
        for lab, ref_values in ((st.q2, ref.q2), (st.torque, ref.torque)):
            c_lab = np.corrcoef(on_grid(ref, ref_values), on_grid(st, lab))[0, 1]
            c_motor = np.corrcoef(on_grid(ref, ref_values), on_grid(st, s * lab))[0, 1]
            assert c_lab > 0.85
            assert c_motor == pytest.approx(c_lab if s == 1 else -c_lab)
        # the BF swing goes from the back bar (q2 < 0) to the front bar (q2 > 0)
        assert st.q2[0] < -1.8 and st.q2[-1] > 1.8
        assert st.q1[0] < -0.5 and st.q1[-1] > 0.5


@pytest.mark.parametrize("name", FLAGGED)
def test_the_shoulder_rate_is_the_shoulder_angles_derivative(name):
    log = _log(name)
    for s in swings(log):
        st = swing_state(log, s)
        slope = np.gradient(st.q1, st.time)
        assert np.corrcoef(slope, st.q1_rate)[0, 1] > 0.8
        slope2 = np.gradient(st.q2, st.time)
        assert np.corrcoef(slope2, st.q2_rate)[0, 1] > 0.8


@pytest.mark.parametrize("name", FLAGGED)
def test_at_a_hand_over_the_shoulder_changes_link_and_the_elbow_keeps_its_sign(name):
    """After a catch the logger's shoulder refers to the new holding link (its sign flips,
    and it lands on the closed-chain angle from the elbow), while the elbow encoder keeps
    its value: the lab's q2 flips through the elbow sign."""
    log = _log(name)
    hs = hand_overs(log)
    assert len(hs) == 4
    for h in hs:
        assert h.shoulder_before > 0.5 and h.shoulder_after < -0.5
        assert abs(h.elbow_after - h.elbow_before) < 0.05 and abs(h.elbow_before) > 1.9
        assert abs(h.shoulder_after - h.chain_shoulder_after) < 0.05
        # the schedule: the catch torque, then the release torque of opposite sign
        assert abs(h.clipped_torque_before) == 0.8 and abs(h.clipped_torque_after) == 2.5
        assert np.sign(h.clipped_torque_before) != np.sign(h.clipped_torque_after)


def test_closed_chain_shoulder():
    for q2 in (1.2, 2.0, -1.5, -2.1):
        q1 = closed_chain_shoulder(q2)
        assert np.cos(q1) + np.cos(q1 + q2) == pytest.approx(0.0, abs=1e-12)
        assert np.sign(q1) == np.sign(q2)


# --- which torque was applied --------------------------------------------------------------------
def test_the_pd_runs_command_no_torque_the_servo_applies_one():
    log = _log("BF_pd_5x")
    for s in swings(log):
        assert np.all(log.columns["elbow_clipped_tau"][s.rows] == 0.0)
        assert np.max(np.abs(log.elbow_torque[s.rows])) > 0.5


def test_the_catch_logs_a_torque_the_servo_does_not_apply_at_first():
    """The catch's first 0.1 s: the clipped column holds +-0.8 N m, the servo measures
    about 0 (it idles); the last 0.05 s: both are +-0.8 N m."""
    log = _log("BF_tvlqr_5x")
    edges = np.diff(np.r_[0, (log.phase == CATCH).astype(int), 0])
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)):
        t = log.time[a:b] - log.time[a]
        clipped, meas = log.columns["elbow_clipped_tau"][a:b], log.elbow_torque[a:b]
        idle = (t > 0.1) & (t < 0.2)
        hold = t > t[-1] - 0.05
        assert np.all(np.abs(clipped) == 0.8)
        assert abs(np.mean(meas[idle])) < 0.05
        assert np.mean(meas[hold]) == pytest.approx(np.mean(clipped[hold]), abs=0.1)


def test_in_a_tvlqr_swing_the_measured_torque_follows_the_command():
    log = _log("BF_tvlqr_5x")
    for s in swings(log):
        c = np.corrcoef(log.columns["elbow_clipped_tau"][s.rows], log.elbow_torque[s.rows])
        assert c[0, 1] > 0.5


# --- sensor floor --------------------------------------------------------------------------------
@pytest.mark.parametrize("path", PATHS, ids=lambda p: p.name)
def test_the_elbow_angle_lies_on_the_encoder_grid(path):
    log = read_log(path)
    assert elbow_grid_deviation(log) < 0.01
    assert elbow_step(log) == pytest.approx(ELBOW_ENCODER_STEP, rel=0.01) or \
        elbow_step(log) == pytest.approx(2 * ELBOW_ENCODER_STEP, rel=0.01)


@pytest.mark.parametrize("name", FLAGGED)
def test_sensor_floor(name):
    log = _log(name)
    f = sensor_floor(log)
    assert f.stretches == 5
    assert 0.0 < f.elbow_std < 2e-3 and 0.0 < f.shoulder_std < 2e-3
    # the shoulder estimate drifts: its offset from the closed chain falls by > 0.04 rad
    assert f.shoulder_offset[0] - f.shoulder_offset[-1] > 0.04
    assert f.offset_drift < -3e-3
    assert abs(f.shoulder_offset[0]) < 0.02


def test_the_summary_prints_every_log(capsys):
    assert measured.main([str(LOGS)]) == 0
    out = capsys.readouterr().out
    for p in PATHS:
        assert p.name.removesuffix(".csv.gz") in out


def test_the_summary_reports_a_bad_log(tmp_path, capsys):
    bad = _write(tmp_path, ["time,a", "1,2"])
    assert measured.main([str(bad)]) == 1
    assert "bad.csv:1:" in capsys.readouterr().err
