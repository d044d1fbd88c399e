"""AcroMonk's measured swings replayed (monkeystudy.analysis.measured_replay): the frame
mapping, the torque's hold, the errors, and the identification on a simulated swing."""
from __future__ import annotations

import numpy as np
import pytest

from monkeystudy.analysis.measured_replay import (
    ModelSwing, ModelValues, acromonk_robot, held_torque, horizon_errors, identify,
    model_swings, replay, start_rows,
)
from monkeystudy.measured import CATCH, SHIPPED_LOGS, read_log, swings_by_flag
from monkeystudy.robot import Friction
from monkeystudy.simulation import physical_points


@pytest.fixture(scope="module")
def robot():
    return acromonk_robot()


@pytest.fixture(scope="module")
def pd_swings():
    return model_swings(read_log(SHIPPED_LOGS / "BF_pd_5x.csv.gz"))


def _free_end(robot, theta1, theta2, flipped):
    s = np.zeros(8)
    s[2], s[3] = theta1, theta2
    pts = physical_points(robot.params(), s[None], np.array([float(flipped)]))
    return pts["B" if flipped == 0 else "A"][0]


# --- the frame ----------------------------------------------------------------------------------
def test_the_holding_hook_picks_the_parameter_row(pd_swings):
    # BF_pd_5x: the motor arm (URDF hook_1, end A) holds for swings 1, 3, 5
    assert [ms.flipped for ms in pd_swings] == [0, 1, 0, 1, 0]


@pytest.mark.parametrize("name", ["BF_pd_5x", "BF_tvlqr_5x"])
def test_the_first_catch_closes_the_chain_on_the_next_bar(robot, name):
    # the last 0.05 s of the first catch: both hooks on bars 0.34 m apart at one height; in
    # the model frame of the finished swing the free end must sit on the bar's height. The
    # URDF's hook-frame offset (-0.0636 rad) would put it 3 cm off.
    log = read_log(SHIPPED_LOGS / f"{name}.csv.gz")
    first = swings_by_flag(log)[0]
    ms = model_swings(log)[0]
    stop = first.stop
    while stop < len(log) and log.phase[stop] == CATCH:
        stop += 1
    rows = np.arange(first.stop, stop)
    rows = rows[log.time[rows] >= log.time[stop - 1] - 0.05]
    s = 1 if ms.flipped == 0 else -1
    th1, th2 = float(np.mean(log.shoulder_angle[rows])), float(np.mean(s * log.elbow_angle[rows]))
    x, y = _free_end(robot, th1, th2, ms.flipped)
    assert abs(y) < 0.004
    assert 0.33 < x < 0.37
    _, y_urdf = _free_end(robot, th1 - 0.0636, th2, ms.flipped)
    assert abs(y_urdf) > 0.015


def test_the_elbow_torque_drives_theta2_with_its_logged_sign(robot, pd_swings):
    # the torque's sign against the elbow's acceleration: replays with the logged sign follow
    # the elbow several times better over 0.1 s than with the sign reversed
    ms = pd_swings[0]
    reversed_ = ModelSwing(ms.time, ms.theta1, ms.theta2, ms.theta1_rate, ms.theta2_rate,
                           -ms.torque, ms.flipped, ms.name)
    right = horizon_errors(robot, [ms], horizons=(0.1,), every=0.2).rms(0.1)[1]
    wrong = horizon_errors(robot, [reversed_], horizons=(0.1,), every=0.2).rms(0.1)[1]
    assert wrong > 2.5 * right


# --- the hold --------------------------------------------------------------------------------
def test_the_centred_hold_has_no_half_sample_delay():
    # a torque ramp u = t sampled unevenly: the centred hold's impulse to each midpoint equals
    # the ramp's integral to first order; the plain hold lags by half a sample
    rng = np.random.default_rng(1)
    t = np.r_[0.0, np.cumsum(rng.uniform(0.003, 0.015, 60))]
    ends, values = held_torque(t, t, "centred")
    starts = np.r_[0.0, ends[:-1]]
    assert np.all((starts <= t) & (t <= ends + 1e-15))       # each sample inside its piece
    pends, pvalues = held_torque(t, t, "plain")
    assert np.array_equal(pends, t[1:]) and np.array_equal(pvalues, t[:-1])

    def impulse(e, v, at):
        s = np.r_[0.0, e[:-1]]
        return np.sum(v * np.clip(np.minimum(e, at) - s, 0.0, None))

    T = t[-1]
    exact = T * T / 2
    centred_err = abs(impulse(ends, values, T) - exact)
    plain_err = abs(impulse(pends, pvalues, T) - exact)
    dt = np.diff(t)
    assert plain_err == pytest.approx(np.sum(dt * dt) / 2, rel=1e-9)   # half a sample each
    assert centred_err < 0.1 * plain_err


def test_a_repeated_time_stamp_makes_no_piece():
    ends, values = held_torque(np.array([0.0, 0.01, 0.01, 0.02]), np.array([1.0, 2, 3, 4]))
    assert np.all(np.diff(ends) > 0) and ends[-1] == 0.02


# --- the errors ------------------------------------------------------------------------------
def _simulated_swing(robot, ms: ModelSwing) -> ModelSwing:
    """The model's own swing: the measured torque and start, integrated, sampled at the log's
    times."""
    rep = replay(robot, ms, 0, ms.duration + 1.0)
    th = np.vstack([ms.angles[:1], rep.simulated])
    w = np.vstack([[ms.theta1_rate[0], ms.theta2_rate[0]], rep.simulated_rates])
    keep = np.r_[True, np.diff(ms.time) > 0]
    return ModelSwing(ms.time[keep], th[:, 0], th[:, 1], w[:, 0], w[:, 1], ms.torque[keep],
                      ms.flipped, ms.name + " simulated")


def test_errors_are_zero_on_the_models_own_swing_and_count_right(robot, pd_swings):
    ms = pd_swings[0]
    own = _simulated_swing(robot, ms)
    he = horizon_errors(robot, [own], every=0.1)
    for h in (0.1, 0.2, 0.5):
        assert he.count(h) == len(start_rows(own, 0.1, h))
        assert np.max(np.abs(he.errors[h])) < 1e-5
    # on a logged swing: the error at 0.2 s of the start at 0.3 s is the replay's simulated
    # less the logged angles at the first sample at or after 0.2 s past that start
    real = horizon_errors(robot, [ms], horizons=(0.2,), every=0.3)
    row = int(start_rows(ms, 0.3, 0.2)[1])
    rep = replay(robot, ms, row, 0.3)
    k = int(np.flatnonzero(rep.time >= 0.2 - 1e-9)[0])
    sample = row + 1 + k
    assert ms.time[sample] - ms.time[row] >= 0.2 - 1e-9 > ms.time[sample - 1] - ms.time[row]
    assert np.array_equal(real.errors[0.2][1], rep.simulated[k] - ms.angles[sample])


@pytest.mark.slow
def test_identification_recovers_the_friction_of_a_simulated_swing(pd_swings):
    # the honest test of the method: a swing made by the simulator with known friction,
    # sampled at a log's times with its measured torque, refitted from a different start
    truth = ModelValues(Friction(0.03, 0.02), Friction(0.05, 0.04))
    base = acromonk_robot()
    own = _simulated_swing(truth.robot(base), pd_swings[0])
    fit = identify(base, [own], window=0.3, every=0.1, max_nfev=40)
    want = np.array([0.03, 0.02, 0.05, 0.04])
    assert np.allclose(fit.values, want, atol=2e-3), fit.table()
    assert fit.rms < 1e-4
