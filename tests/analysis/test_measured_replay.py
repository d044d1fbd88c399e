"""AcroMonk's measured swings replayed (monkeystudy.analysis.measured_replay): the frame
mapping, the torque's hold, the errors, and the identification on a simulated swing."""
from __future__ import annotations

import numpy as np
import pytest

from dataclasses import replace

from monkeystudy.analysis.measured_replay import (
    PUBLISHED_JOINT, PUBLISHED_PIVOT, ModelSwing, ModelValues, acromonk_robot, chain_closure,
    held_torque, horizon_errors, identify, inverse_dynamics, local_quadratic, model_swings,
    rate_agreement, rate_noise, replay, rest_shoulder, simulated_swing, start_rows,
    torque_sign_errors,
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


@pytest.mark.parametrize("name", ["BF_pd_5x", "BF_tvlqr_5x"])
def test_chain_closure_puts_the_free_end_on_the_next_bar(robot, name):
    # the same check through chain_closure (tools/acromonk_replay.py --checks): bars 0.34 m
    # apart at one height; the URDF's hook-frame offset moves the free end off the bar
    c = chain_closure(robot, read_log(SHIPPED_LOGS / f"{name}.csv.gz"))
    assert abs(c.free_end[1]) < 0.004 and 0.33 < c.free_end[0] < 0.37
    assert c.urdf_offset == pytest.approx(-0.0636, abs=1e-4)
    assert abs(c.free_end_urdf[1]) > 0.015


def test_torque_sign_errors_favour_the_logged_sign(robot, pd_swings):
    right, wrong = torque_sign_errors(robot.with_friction(PUBLISHED_PIVOT, PUBLISHED_JOINT),
                                      pd_swings[0])
    assert wrong > 2.5 * right
    # the two are the same replays with the torque's sign swapped
    flipped = replace(pd_swings[0], torque=-pd_swings[0].torque)
    assert torque_sign_errors(robot.with_friction(PUBLISHED_PIVOT, PUBLISHED_JOINT),
                              flipped) == (wrong, right)


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
def _simulated_swing(robot, ms: ModelSwing, torque_scale: float = 1.0) -> ModelSwing:
    """The model's own swing: the measured torque (times ``torque_scale``) and start,
    integrated, sampled at the log's times; the torque it carries is the measured one."""
    rep = replay(robot, ms, 0, ms.duration + 1.0, torque_scale=torque_scale)
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


@pytest.mark.slow
def test_identification_recovers_the_rotor_and_the_torque_scale_of_a_simulated_swing(pd_swings):
    # a swing from the motor arm and one from the IMU arm (the rotor's block differs between
    # the frames: 36 and 25 times its inertia), made with a known rotor inertia, a known scale
    # on the measured torque and friction at the elbow
    truth = ModelValues(joint=Friction(0.05), torque_scale=0.85, rotor_inertia=2.5e-4)
    base = acromonk_robot()
    own = [_simulated_swing(truth.robot(base), ms, torque_scale=0.85) for ms in pd_swings[:2]]
    assert {ms.flipped for ms in own} == {0, 1}
    fit = identify(base, own, names=("joint_viscous", "rotor_inertia", "torque_scale"),
                   window=0.3, every=0.1, max_nfev=40)
    assert np.allclose(fit.values, [0.05, 2.5e-4, 0.85], rtol=1e-2, atol=1e-6), fit.table()
    assert fit.rms < 1e-4


def test_identify_says_each_residual_evaluation_as_it_makes_it():
    """The identification (minutes on studies/acromonk.yaml) said nothing until it
    was over. ``evaluated(1)`` comes once per residual evaluation, as it is made: at least
    least_squares' own (its nfev) and the fit's last, at most :func:`identify_evaluations`
    (its Jacobians' too), and the fit is the one made without it."""
    sws = model_swings(read_log(SHIPPED_LOGS / "ZB_pd_1x.csv.gz"))
    base = acromonk_robot()
    said = []
    fit = identify(base, sws, names=("joint_viscous", "torque_scale"), window=0.3, every=0.3,
                   max_nfev=3, evaluated=said.append)
    assert set(said) == {1}
    from monkeystudy.analysis.measured_replay import identify_evaluations
    assert fit.nfev + 1 <= len(said) <= identify_evaluations(3, 2) == 3 * 3 + 1
    silent = identify(base, sws, names=("joint_viscous", "torque_scale"), window=0.3,
                      every=0.3, max_nfev=3)
    assert np.array_equal(silent.values, fit.values) and silent.rms == fit.rms


# --- the checks of the signals ----------------------------------------------------------------
def _sine_swing(rate_factor=1.0, seed=3) -> ModelSwing:
    """theta = (sin 3t, cos 2t) at uneven times 3-15 ms apart, the rates exact times a
    factor."""
    rng = np.random.default_rng(seed)
    t = np.r_[0.0, np.cumsum(rng.uniform(0.003, 0.015, 200))]
    return ModelSwing(t, np.sin(3 * t), np.cos(2 * t), rate_factor * 3 * np.cos(3 * t),
                      rate_factor * -2 * np.sin(2 * t), np.zeros_like(t), 0, "sine")


def test_rate_agreement_measures_rates_against_angles():
    good = rate_agreement(_sine_swing())
    assert np.all(good.integrated < 1e-3) and np.all(good.quotient < 0.01)
    bad = rate_agreement(_sine_swing(rate_factor=1.1))   # rates 10 % too large
    assert np.all(bad.integrated > 0.05) and np.all(bad.quotient > 0.1)


def test_local_quadratic_is_exact_on_a_quadratic_and_smooths_noise():
    rng = np.random.default_rng(4)
    t = np.r_[0.0, np.cumsum(rng.uniform(0.003, 0.015, 300))]
    y = 2.0 - 3.0 * t + 5.0 * t * t
    value, slope = local_quadratic(t, y, 0.025)
    assert np.allclose(value, y, atol=1e-10) and np.allclose(slope, -3.0 + 10.0 * t, atol=1e-8)
    noisy = y + 0.1 * rng.normal(size=t.size)
    _, smooth = local_quadratic(t, noisy, 0.025)
    raw = np.gradient(noisy, t)
    truth = -3.0 + 10.0 * t
    assert np.std(smooth - truth) < 0.3 * np.std(raw - truth)
    with pytest.raises(ValueError, match="fewer than 3 samples"):
        local_quadratic(t, y, 0.001)


def test_inverse_dynamics_of_the_models_own_swing_is_its_friction(robot, pd_swings):
    # the model's own swing (published damping): its pivot row is -b1 w1 and its elbow row
    # the torque less b2 w2, to the differentiator's error; the other parameter row is not
    published = robot.with_friction(PUBLISHED_PIVOT, PUBLISHED_JOINT)
    own = simulated_swing(published, pd_swings[0])
    i = inverse_dynamics(published, own, differentiator="difference", half_width=0.025)
    assert i.pivot_rms < 0.01
    # the elbow's quotient straddles the held torque's steps (at the midpoints between
    # samples; up to ~0.3 N m each): a few 0.01 N m, against 0.26-0.51 N m on the logs
    assert i.elbow_rms < 0.1 and i.torque_factor == pytest.approx(1.0, abs=0.05)
    # without the friction the rows are the friction torques
    bare = inverse_dynamics(robot, own, differentiator="difference", half_width=0.025)
    assert np.allclose(bare.pivot + PUBLISHED_PIVOT.viscous * bare.rates[:, 0], i.pivot)
    q = inverse_dynamics(published, own, differentiator="local_quadratic", half_width=0.025)
    assert q.pivot_rms < 0.03
    assert np.array_equal(q.time, i.time)          # both scored on the same samples
    swapped = inverse_dynamics(published, own, differentiator="difference", half_width=0.025,
                               flipped=1)
    assert swapped.pivot_rms > 10 * i.pivot_rms and swapped.elbow_rms > 3 * i.elbow_rms


def test_rate_noise_finds_added_noise_and_smoothing_removes_its_torque(robot, pd_swings):
    published = robot.with_friction(PUBLISHED_PIVOT, PUBLISHED_JOINT)
    clean = simulated_swing(published, pd_swings[0])
    noisy = simulated_swing(published, pd_swings[0], rate_noise_std=(0.1, 0.1), seed=5)
    assert np.all(rate_noise(clean) < 0.03)
    assert np.allclose(rate_noise(noisy), 0.1, rtol=0.25)
    raw = inverse_dynamics(published, noisy, differentiator="difference", half_width=0.025)
    smooth = inverse_dynamics(published, noisy, differentiator="local_quadratic",
                              half_width=0.025)
    assert raw.pivot_rms > 1.0 > 3 * smooth.pivot_rms


def test_the_logged_shoulder_sign_fits_the_pivot_row_on_both_hooks(robot, pd_swings):
    # theta1 with its sign reversed: the pivot row's residual grows several times on the
    # swings from either hook (a sign error on one hook would show on its swings only)
    for ms in pd_swings[:2]:
        neg = replace(ms, theta1=-ms.theta1, theta1_rate=-ms.theta1_rate)
        kw = dict(differentiator="local_quadratic", half_width=0.025)
        assert inverse_dynamics(robot, neg, **kw).pivot_rms > \
            2.5 * inverse_dynamics(robot, ms, **kw).pivot_rms


@pytest.mark.parametrize("row", [0, 1])
def test_rest_shoulder_puts_the_cg_under_the_pivot(robot, row):
    # with the elbow held at 0 the robot is one rigid body: at rest its CG hangs straight
    # below the pivot (the frame's origin), and 0.01 rad away it does not
    def cg_x(th1):
        s = np.zeros(8)
        s[2] = th1
        pts = physical_points(robot.params(), s[None], np.array([float(row)]))
        m1, m2 = robot.link1.mass, robot.link2.mass
        return float((m1 * pts["cg1"][0, 0] + m2 * pts["cg2"][0, 0]) / (m1 + m2))

    th1 = rest_shoulder(robot, row)
    assert abs(cg_x(th1)) < 1e-12
    assert abs(cg_x(th1 + 0.01)) > 1e-3


def test_the_energy_budget_of_the_models_own_swing_is_its_friction(robot, pd_swings):
    # a swing the model made: without friction the measured torque's work is the energy's
    # change (the trapezoids' error only); with viscous friction the budget's loss is the
    # friction's dissipation, and the energy-only estimate finds that friction again
    from monkeystudy.analysis.measured_replay import (
        energy_balance, rate_square_integrals, viscous_from_energy)

    bare = energy_balance(robot, simulated_swing(robot, pd_swings[0]))
    assert abs(bare.dissipated) < 0.02 * abs(bare.motor_work)
    damped_robot = robot.with_friction(Friction(0.03), Friction(0.05))
    damped = [simulated_swing(damped_robot, ms) for ms in pd_swings[:3]]
    for ms in damped:
        loss = np.dot([0.03, 0.05], rate_square_integrals(ms))
        assert energy_balance(robot, ms).dissipated == pytest.approx(loss, rel=0.05)
    assert viscous_from_energy(robot, damped) == pytest.approx([0.03, 0.05], abs=0.005)
