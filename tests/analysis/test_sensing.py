"""Sensor models of a walked route (monkeystudy.analysis.sensing): the forward kinematics
against the kernel's flip, how each model's error grows with the number of catches, the
encoder's quantisation bound, the range finder's grid, the markers' reset and the draws'
determinism."""
from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from monkeystudy.analysis.sensing import (
    PER_RUN_CATCH, Exact, Markers, Odometry, RangeFinder, SensorDraws, frame_lengths, quantise,
    sensor_draws, sensor_from_dict, step_vector,
)
from monkeystudy.kernel.dynamics import flip_state, free_end_offset
from monkeystudy.robot import Link, Robot

SEED = 20261128
RUNS = 2000
N_SHORT, N_LONG = 10, 40
#: seed2009's links [m]
EQUAL = (0.61, 0.61)
#: a robot whose links differ, so that exchanging them shows
UNEQUAL_ROBOT = Robot(Link(1.0, 0.61, 0.3, 0.03), Link(0.7, 0.43, 0.2, 0.012))
UNEQUAL = (UNEQUAL_ROBOT.link1.length, UNEQUAL_ROBOT.link2.length)
#: a horizontal brachiation of equal links: B at A's height (theta2 = pi - 2 theta1)
TH1 = 0.9
HORIZONTAL = (TH1, math.pi - 2 * TH1)


def walk(model, thetas, ends, seed, run, *, lengths=EQUAL, start=(0.3, 1.2), draws=None):
    """Walk ``model`` over the catches ``thetas`` (each in the frame of the end in ``ends``)
    and return the errors ``estimate - true`` [m] after each catch, shape (n, 2), and the
    error at the start. The truth adds each catch's exact step vector."""
    true = np.array(start, dtype=float)
    first = draws[0] if draws is not None else sensor_draws(seed, run, 0)
    est = model.initial(true, first)
    start_error = est - true
    errors = []
    for k, (theta, end) in enumerate(zip(thetas, ends)):
        d = draws[k] if draws is not None else sensor_draws(seed, run, k)
        after = true + step_vector(*theta, frame_lengths(lengths, end))
        est = model.update(est, true, after, theta, d, lengths=lengths, attached=end)
        true = after
        errors.append(est - true)
    return np.array(errors), start_error


def alternating(n):
    """The ends of ``n`` brachiations from A: A, B, A, ..."""
    return ["A" if k % 2 == 0 else "B" for k in range(n)]


@pytest.fixture(scope="module")
def draws_table():
    """``RUNS`` runs of ``N_LONG`` catches' draws under ``SEED``."""
    return [[sensor_draws(SEED, run, k) for k in range(N_LONG)] for run in range(RUNS)]


def final_errors(model, draws_table, thetas, ends, lengths=EQUAL):
    """Errors after ``N_SHORT`` and ``N_LONG`` catches of every run, shape (RUNS, 2) each."""
    short, long_ = [], []
    for run, draws in enumerate(draws_table):
        e, _ = walk(model, thetas, ends, SEED, run, lengths=lengths, draws=draws)
        short.append(e[N_SHORT - 1])
        long_.append(e[N_LONG - 1])
    return np.array(short), np.array(long_)


# -- the forward kinematics are the kernel's ----------------------------------------------------
@pytest.mark.parametrize("attached", ["A", "B"])
def test_step_vector_is_the_kernels_free_end_in_either_frame(attached):
    par = UNEQUAL_ROBOT.params()[0 if attached == "A" else 1]
    rng = np.random.default_rng(1)
    for th1, th2 in rng.uniform(-math.pi, math.pi, size=(50, 2)):
        want = free_end_offset(par, th1, th2)
        np.testing.assert_allclose(step_vector(th1, th2, frame_lengths(UNEQUAL, attached)),
                                   want, rtol=0, atol=1e-15)


def test_error_free_odometry_follows_50_of_the_kernels_magnet_swaps():
    """Fifty brachiations of a robot with unequal links, each swap the kernel's flip from the
    frame it hung in: the error-free dead reckoning lands on every catch (1e-12 m)."""
    params = UNEQUAL_ROBOT.params()
    s = np.zeros(8)
    s[:2] = (0.4, 2.0)
    flipped = 0
    est = Odometry().initial(s[:2], SensorDraws())
    rng = np.random.default_rng(2)
    for k in range(50):
        s[2], s[3] = rng.uniform(-math.pi, math.pi, size=2)
        before, theta = s[:2].copy(), (s[2], s[3])
        flip_state(params[flipped], s)          # the free end catches, the frame flips
        end = "AB"[flipped]
        est = Odometry().update(est, before, s[:2], theta, sensor_draws(SEED, 0, k),
                                lengths=UNEQUAL, attached=end)
        flipped = 1 - flipped
        assert np.max(np.abs(est - s[:2])) < 1e-12, k


def test_exact_estimate_is_the_truth():
    rng = np.random.default_rng(3)
    thetas = rng.uniform(-2.0, 2.0, size=(200, 2))
    errors, start = walk(Exact(), thetas, alternating(200), SEED, 5, lengths=UNEQUAL)
    assert not np.any(errors) and not np.any(start)


# -- dead reckoning: noise is a random walk, an offset a drift ----------------------------------
def test_encoder_noise_makes_the_height_a_random_walk(draws_table):
    """Each catch's encoder error moves that step's y by ``L2 sin(th1 + th2) dtheta2``: the
    final y error's variance grows as ``n sigma^2 (L2 sin(th1 + th2))^2``, its mean ~0."""
    sigma = 1e-3
    model = Odometry(angle_noise=sigma)
    short, long_ = final_errors(model, draws_table, [HORIZONTAL] * N_LONG, alternating(N_LONG))
    var_short, var_long = short[:, 1].var(ddof=1), long_[:, 1].var(ddof=1)
    ratio = var_long / var_short
    print(f"encoder noise: var(y) at {N_SHORT}: {var_short:.4e} m2, at {N_LONG}: "
          f"{var_long:.4e} m2, ratio {ratio:.3f}")
    assert 3.2 <= ratio <= 4.8
    per_step = (EQUAL[1] * math.sin(sum(HORIZONTAL)) * sigma) ** 2
    assert 0.85 <= var_long / (N_LONG * per_step) <= 1.15
    for e in (short[:, 1], long_[:, 1]):
        assert abs(e.mean()) <= 4 * e.std(ddof=1) / math.sqrt(RUNS)


def test_inclinometer_noise_makes_the_height_a_random_walk(draws_table):
    """A theta1 error turns the whole step: ``dy = dx_step * dtheta1`` per catch."""
    sigma = 1e-3
    model = Odometry(imu_noise=sigma)
    short, long_ = final_errors(model, draws_table, [HORIZONTAL] * N_LONG, alternating(N_LONG))
    ratio = long_[:, 1].var(ddof=1) / short[:, 1].var(ddof=1)
    assert 3.2 <= ratio <= 4.8
    dx = step_vector(*HORIZONTAL, EQUAL)[0]
    assert 0.85 <= long_[:, 1].var(ddof=1) / (N_LONG * (dx * sigma) ** 2) <= 1.15
    assert abs(long_[:, 1].mean()) <= 4 * long_[:, 1].std(ddof=1) / math.sqrt(RUNS)


@pytest.mark.parametrize("field", ["angle_bias", "imu_bias"])
def test_an_offset_drifts_linearly_over_steps_from_one_end(field):
    """The same step from the same end, one run's offset: the error after 40 catches is 4
    times the error after 10 (round-off aside), and not zero."""
    model = Odometry(**{field: 2e-3})
    for run in range(3):
        errors, _ = walk(model, [HORIZONTAL] * N_LONG, ["A"] * N_LONG, SEED, run)
        short, long_ = errors[N_SHORT - 1], errors[N_LONG - 1]
        assert np.linalg.norm(short) > 1e-5
        # atol: the round-off of positions tens of metres from the origin
        np.testing.assert_allclose(long_, (N_LONG / N_SHORT) * short, rtol=1e-9, atol=1e-12)


def test_an_inclinometer_offset_drifts_linearly_over_brachiations():
    """Alternating ends, each link with its own offset: the error over 40 catches is 4 times
    the error over 10 (both an even number of catches)."""
    model = Odometry(imu_bias=2e-3)
    errors, _ = walk(model, [HORIZONTAL] * N_LONG, alternating(N_LONG), SEED, 1)
    np.testing.assert_allclose(errors[N_LONG - 1], 4 * errors[N_SHORT - 1], rtol=1e-9,
                               atol=1e-12)
    assert np.linalg.norm(errors[N_SHORT - 1]) > 1e-5


def test_an_encoder_offset_cancels_over_a_symmetric_gaits_pair_of_steps():
    """The encoder reads the physical joint angle, ``theta2`` from A and ``-theta2`` from B:
    a symmetric gait's steps from A and from B see the offset with opposite signs, and the
    first-order errors cancel pairwise; what stays is of second order, ``L2 b^2`` per pair,
    while the same steps all from A drift by ``L2 |sin(th1 + th2)| b`` per step."""
    b = 2e-3
    model = Odometry(angle_bias=b)
    run = 0
    offset = b * sensor_draws(SEED, run, 0).encoder_bias
    paired, _ = walk(model, [HORIZONTAL] * N_LONG, alternating(N_LONG), SEED, run)
    one_end, _ = walk(model, [HORIZONTAL] * N_LONG, ["A"] * N_LONG, SEED, run)
    assert np.linalg.norm(paired[-1]) <= (N_LONG / 2) * EQUAL[1] * offset ** 2
    drift = N_LONG * EQUAL[1] * abs(math.sin(sum(HORIZONTAL)) * offset)
    assert abs(one_end[-1, 1]) == pytest.approx(drift, rel=1e-2)


# -- the encoder's resolution -------------------------------------------------------------------
def test_encoder_resolution_bounds_each_steps_error_closely():
    """A reading rounded to a multiple of ``q`` is off by at most ``q/2``, so the step by at
    most ``L2 q/2`` (the far link turns about the joint); both bounds are nearly attained."""
    q = 0.01
    model = Odometry(encoder_resolution=q)
    rng = np.random.default_rng(4)
    angle_errors, step_errors = [], []
    for k in range(2000):
        theta = tuple(rng.uniform(-3.0, 3.0, size=2))
        end = "AB"[k % 2]
        read1, read2 = model.read_angles(theta, SensorDraws(), end)
        assert read1 == theta[0]
        assert abs(read2 / q - round(read2 / q)) < 1e-9          # a multiple of q
        angle_errors.append(abs(read2 - theta[1]))
        frame = frame_lengths(UNEQUAL, end)
        est = model.update((0.0, 0.0), (0.0, 0.0), step_vector(*theta, frame), theta,
                           SensorDraws(), lengths=UNEQUAL, attached=end)
        step_errors.append(np.linalg.norm(est - step_vector(*theta, frame)) / (frame[1] * q / 2))
    angle_errors = np.array(angle_errors) / (q / 2)
    step_errors = np.array(step_errors)
    print(f"resolution: max |dtheta2| = {angle_errors.max():.5f} q/2, max |dstep| = "
          f"{step_errors.max():.5f} L2 q/2")
    assert angle_errors.max() <= 1 + 1e-9 and angle_errors.max() >= 0.99
    assert step_errors.max() <= 1 + 1e-9 and step_errors.max() >= 0.99


def test_quantise_rounds_to_the_nearest_multiple():
    assert quantise(0.0149, 0.01) == pytest.approx(0.01, abs=1e-15)
    assert quantise(-0.0151, 0.01) == pytest.approx(-0.02, abs=1e-15)
    assert quantise(0.123456, 0.0) == 0.123456


# -- the range finder ---------------------------------------------------------------------------
def test_range_finders_height_error_does_not_grow_and_is_on_its_grid(draws_table):
    noise, bias, q = 2e-3, 5e-3, 1e-3
    model = RangeFinder(noise=noise, bias=bias, resolution=q,
                        odometry=Odometry(angle_noise=1e-3))
    rng = np.random.default_rng(5)
    thetas = [(TH1 + a, math.pi - 2 * TH1 + b)
              for a, b in rng.uniform(-0.05, 0.05, size=(N_LONG, 2))]   # heights off the grid
    short, long_ = [], []
    for run, draws in enumerate(draws_table):
        true = np.array((0.3, 1.2345678))
        est = model.initial(true, draws[0])
        assert abs(est[1] / q - round(est[1] / q)) < 1e-9
        for k, theta in enumerate(thetas):
            end = "AB"[k % 2]
            after = true + step_vector(*theta, frame_lengths(EQUAL, end))
            est = model.update(est, true, after, theta, draws[k], lengths=EQUAL, attached=end)
            true = after
            assert abs(est[1] / q - round(est[1] / q)) < 1e-9        # a multiple of q
            if k + 1 == N_SHORT:
                short.append(est - true)
        long_.append(est - true)
    short, long_ = np.array(short), np.array(long_)
    y_ratio = long_[:, 1].var(ddof=1) / short[:, 1].var(ddof=1)
    x_ratio = long_[:, 0].var(ddof=1) / short[:, 0].var(ddof=1)
    print(f"range finder: var(y) ratio {y_ratio:.3f}, var(x) ratio {x_ratio:.3f}")
    assert 0.8 <= y_ratio <= 1.25
    # the reading's error: the run's offset, the catch's noise and the rounding
    want = bias ** 2 + noise ** 2 + q ** 2 / 12
    assert 0.85 <= short[:, 1].var(ddof=1) / want <= 1.15
    assert 3.2 <= x_ratio <= 4.8                                   # x is dead reckoned


def test_range_finder_with_exact_x_has_no_x_error():
    model = RangeFinder(noise=1e-3, x_from="exact", odometry=Odometry(angle_noise=1e-2))
    errors, _ = walk(model, [HORIZONTAL] * 20, alternating(20), SEED, 3)
    assert not np.any(errors[:, 0]) and np.all(errors[:, 1] != 0)


# -- markers ------------------------------------------------------------------------------------
def test_a_marker_resets_the_error_and_odometry_adds_up_again_after_it():
    odometry = Odometry(angle_noise=2e-3, imu_noise=2e-3)
    n, at = 12, 5
    ends = alternating(n)
    true = np.array([[0.3, 1.2]])
    for k in range(n):
        true = np.vstack([true, true[-1] + step_vector(*HORIZONTAL, frame_lengths(EQUAL, ends[k]))])
    noise = 1e-4
    model = Markers([(true[at + 1, 0] + 0.01, true[at + 1, 1]), (-50.0, -50.0)], radius=0.02,
                    noise=noise, odometry=odometry)
    errors, _ = walk(model, [HORIZONTAL] * n, ends, SEED, 7)
    plain, _ = walk(odometry, [HORIZONTAL] * n, ends, SEED, 7)
    np.testing.assert_array_equal(errors[:at], plain[:at])           # no marker yet
    d = sensor_draws(SEED, 7, at)
    np.testing.assert_allclose(errors[at], noise * np.array([d.marker_x, d.marker_y]),
                               rtol=0, atol=1e-15)
    assert np.linalg.norm(plain[at]) > 10 * np.linalg.norm(errors[at])
    # after it the odometry's own per-catch errors add up from the reset error again
    np.testing.assert_allclose(errors[at + 1:] - errors[at], plain[at + 1:] - plain[at],
                               rtol=0, atol=1e-14)


def test_a_marker_is_read_on_its_rim_and_not_beyond():
    d = SensorDraws(marker_x=1.0, marker_y=-1.0, encoder=1.0)
    odometry = Odometry(angle_noise=0.1)
    args = ((9.0, 9.0), (1.0, 1.61), (1.0, 1.0), (0.0, 0.0), d)
    on_rim = Markers([(1.25, 1.0)], radius=0.25, noise=0.0, odometry=odometry)
    beyond = Markers([(1.25, 1.0)], radius=0.2499, noise=0.0, odometry=odometry)
    np.testing.assert_array_equal(on_rim.update(*args, lengths=EQUAL, attached="A"), (1.0, 1.0))
    far = beyond.update(*args, lengths=EQUAL, attached="A")
    np.testing.assert_array_equal(far, odometry.update(*args, lengths=EQUAL, attached="A"))
    assert np.linalg.norm(far - (9.0, 9.0)) > 0.5        # dead reckoned from the old estimate


# -- the draws ----------------------------------------------------------------------------------
def test_draws_depend_only_on_seed_run_and_catch():
    keys = [(SEED, run, catch) for run in (0, 1, 2**64 - 1) for catch in (0, 1, 7)]
    first = {k: sensor_draws(*k) for k in keys}
    for k in reversed(keys):                                   # another order, fresh calls
        assert sensor_draws(*k) == first[k]
    a, b = first[(SEED, 0, 0)], first[(SEED, 0, 1)]
    assert (a.imu, a.encoder, a.range_finder, a.marker_x, a.marker_y) != (
        b.imu, b.encoder, b.range_finder, b.marker_x, b.marker_y)
    assert len({a.imu, b.imu, first[(SEED, 0, 7)].imu}) == 3
    # the run's offsets are one draw per run
    assert (a.imu_bias_link1, a.encoder_bias, a.range_bias) == (
        b.imu_bias_link1, b.encoder_bias, b.range_bias)
    c = first[(SEED, 1, 0)]
    assert a.encoder_bias != c.encoder_bias and a.encoder != c.encoder
    assert sensor_draws(SEED + 1, 0, 0) != a


def test_another_process_draws_the_same_numbers():
    """A worker process gets the same draws for the same keys as this one."""
    code = ("from monkeystudy.analysis.sensing import sensor_draws\n"
            "print(repr([sensor_draws(5, r, c) for r, c in ((0, 0), (3, 17), (2**40, 9))]))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, timeout=120).stdout.strip()
    here = [sensor_draws(5, r, c) for r, c in ((0, 0), (3, 17), (2**40, 9))]
    assert out == repr(here)


def test_draws_are_standard_normals():
    draws = [sensor_draws(11, run, 0) for run in range(4000)]
    z = np.array([[d.encoder, d.encoder_bias] for d in draws])
    assert np.all(np.abs(z.mean(axis=0)) < 4 / math.sqrt(4000))
    assert np.all(np.abs(z.var(axis=0, ddof=1) - 1) < 4 * math.sqrt(2 / 4000))
    assert abs(np.corrcoef(z.T)[0, 1]) < 4 / math.sqrt(4000)


@pytest.mark.parametrize("key", [(-1, 0, 0), (0, -1, 0), (0, 0, -1), (0, 0, PER_RUN_CATCH),
                                 (2**64, 0, 0), (0, 0, 1.5), (0, True, 0)])
def test_draws_refuse_keys_out_of_range(key):
    with pytest.raises(ValueError):
        sensor_draws(*key)


# -- data and validation ------------------------------------------------------------------------
@pytest.mark.parametrize("model", [
    Exact(),
    Odometry(angle_noise=1e-3, angle_bias=2e-3, encoder_resolution=1e-4, imu_noise=3e-3,
             imu_bias=4e-3),
    RangeFinder(noise=1e-3, bias=2e-3, resolution=1e-3, x_from="exact",
                odometry=Odometry(imu_noise=1e-3)),
    Markers([(1.0, 2.0), (3.0, 4.5)], radius=0.1, noise=2e-3, odometry=Odometry(angle_noise=1e-3)),
    Markers([], radius=0.1),
])
def test_a_model_round_trips_through_plain_json_data(model):
    d = json.loads(json.dumps(model.to_dict()))
    assert sensor_from_dict(d) == model


@pytest.mark.parametrize("make, field", [
    (lambda v: Odometry(angle_noise=v), "angle_noise"),
    (lambda v: Odometry(angle_bias=v), "angle_bias"),
    (lambda v: Odometry(encoder_resolution=v), "encoder_resolution"),
    (lambda v: Odometry(imu_noise=v), "imu_noise"),
    (lambda v: Odometry(imu_bias=v), "imu_bias"),
    (lambda v: RangeFinder(noise=v), "noise"),
    (lambda v: RangeFinder(bias=v), "bias"),
    (lambda v: RangeFinder(resolution=v), "resolution"),
    (lambda v: Markers([(0, 0)], radius=v), "radius"),
    (lambda v: Markers([(0, 0)], radius=0.1, noise=v), "noise"),
])
@pytest.mark.parametrize("value", [-1e-3, float("nan")])
def test_a_negative_or_nan_field_is_refused_by_name(make, field, value):
    with pytest.raises(ValueError, match=f"^{field} must be >= 0"):
        make(value)


def test_bad_data_is_refused_naming_what():
    with pytest.raises(ValueError, match="x_from"):
        RangeFinder(x_from="gps")
    with pytest.raises(ValueError, match="unknown key 'noise'"):
        sensor_from_dict({"kind": "odometry", "noise": 0.1})
    with pytest.raises(ValueError, match="sensor kind"):
        sensor_from_dict({"kind": "lidar"})
    with pytest.raises(ValueError, match="radius"):
        sensor_from_dict({"kind": "markers", "positions": [[0, 0]]})
    with pytest.raises(ValueError, match="positions"):
        Markers([(0, 0, 1)], radius=0.1)
    with pytest.raises(ValueError, match="A or B"):
        Odometry().update((0, 0), (0, 0), (0, -1), (0, 0), SensorDraws(), lengths=EQUAL,
                          attached="C")
    with pytest.raises(ValueError, match="lengths"):
        Exact().update((0, 0), (0, 0), (0, -1), (0, 0), SensorDraws(), lengths=(0.6, -0.6),
                       attached="A")
