"""Survival runs and the MFPT estimator (monkeystudy.analysis.survival).

The estimator is checked on processes with a known answer (geometric failures, with and
without censoring); the runs against the deterministic replay they must reduce to without
noise, and for independence from how runs are grouped into blocks."""
import math

import numpy as np
import pytest

from monkeystudy.analysis.replay import section_error, sequence_cycles
from monkeystudy.analysis.survival import (
    Noise, cycle_grid, hazard, mfpt, noise_roles, run_robot, survival_curve, survival_runs,
)
from monkeystudy.controllers import (
    HorizontalSearch, Integrator, OpenLoop, PhaseSequence, Segment, horizontal_gait,
)
from monkeystudy.kernel import layout as L
from monkeystudy.robot import Robot
from monkeystudy.simulation import initial_state

#: the 2009 gait refined on the 1 ms tick (studies/horizontal.yaml, gait1)
GAIT = dict(dtheta1=0.902, dtheta2=10.935, t_switch=0.428, t_motor=0.025)
INTEG = Integrator(rtol=1e-10, atol=1e-12)
REF = (0.0, GAIT["dtheta1"], GAIT["dtheta2"])


def _replay(cycles: int, tick: float = 0.001):
    """The deterministic open-loop replay of the gait (its swap and motor times)."""
    return sequence_cycles(horizontal_gait(0.6354), REF, cycles=cycles, integrator=INTEG,
                           replay="open_loop",
                           times=[GAIT["t_switch"], GAIT["t_switch"] + GAIT["t_motor"]],
                           tick=tick)


def _open_loop(tick=0.001):
    return OpenLoop(GAIT["t_switch"], GAIT["t_motor"], 0.6354, tick=tick)


def _runs(noise, runs, max_cycles=40, **kw):
    return survival_runs(_open_loop(), initial_state(GAIT["dtheta1"], GAIT["dtheta2"]), REF,
                         runs=runs, max_cycles=max_cycles, noise=noise, seed=5,
                         integrator=INTEG, max_drop=0.61, **kw)


# --- the estimator on known answers ----------------------------------------------------------
def _geometric(rng, p, max_cycles, n):
    t = rng.geometric(p, size=n) - 1               # cycles completed before the failing one
    return np.minimum(t, max_cycles), t < max_cycles


@pytest.mark.parametrize("p, max_cycles, n", [(0.01, 2000, 300),    # almost no censoring
                                              (0.002, 300, 300),    # 55 % censored
                                              (0.05, 40, 200)])     # 13 % censored
def test_the_mfpt_interval_covers_a_geometric_process_95_percent_of_the_time(p, max_cycles, n):
    """MFPT = (1 - p) / p cycles; 200 independent studies: the estimate is unbiased to a few
    percent and the 95 % interval covers the truth in 95 % of them (binomial 2-sigma band
    of 200 trials: 0.92-0.98, widened to 0.90-0.99 for the bootstrap's own spread)."""
    rng = np.random.default_rng(12345)
    truth = (1 - p) / p
    covered, estimates = 0, []
    for _ in range(200):
        t, failed = _geometric(rng, p, max_cycles, n)
        m = mfpt(t, failed, max_cycles)
        assert m.method == ("mean" if failed.all() else "tail")
        estimates.append(m.value)
        covered += m.low <= truth <= m.high
    assert abs(np.mean(estimates) / truth - 1) < 0.03
    assert 0.90 <= covered / 200 <= 0.99


def test_without_censoring_the_mfpt_is_the_sample_mean_whatever_the_distribution():
    t = np.array([30, 31, 29, 30, 33, 28, 30, 31])        # an unstable gait's tight drift
    m = mfpt(t, np.ones(t.size, bool), 1000)
    assert m.method == "mean" and m.value == t.mean() and m.censored == 0
    assert m.low <= t.mean() <= m.high and m.high - m.low < 4


def test_no_late_failure_gives_a_lower_bound_only():
    t = np.array([3, 5, 100, 100, 100, 100])              # censored at 100, early failures
    failed = t < 100
    m = mfpt(t, failed, 100)
    assert m.method == "lower_bound" and math.isnan(m.value) and m.high == math.inf
    assert m.low > m.restricted_mean == t.mean()


def test_hazard_counts_failures_and_cycles_at_risk_in_a_window():
    # runs: failed in cycle 3 (2 completed), failed in cycle 8, censored at 10
    t, failed = np.array([2, 7, 10]), np.array([True, True, False])
    assert hazard(t, failed, 0, 10) == (2, 3 + 8 + 10)
    assert hazard(t, failed, 5, 10) == (1, 0 + 3 + 5)


def test_survival_curve_and_its_cycle_grid():
    t = np.array([0, 1, 1, 5, 10])
    assert list(survival_curve(t, 10, [0, 1, 2, 5, 6, 10])) == [1.0, 0.8, 0.4, 0.4, 0.2, 0.2]
    g = cycle_grid(100000)
    assert g[0] == 0 and g[-1] == 100000 and np.all(np.diff(g) > 0) and g.size < 200
    with pytest.raises(ValueError):
        survival_curve(t, 10, [11])


# --- the noise model ---------------------------------------------------------------------------
def test_noise_roles_of_the_open_loop_and_the_state_based_controller():
    ol = noise_roles(_open_loop().program()[0])
    # swap + motor on (time guard: shift), motor off (time guard: shift), clock reset at the
    # vertical (no actuation; reads an angle)
    assert list(ol[:, L.RL_JITTER]) == [L.JITTER_SHIFT, L.JITTER_SHIFT, L.JITTER_NONE]
    assert list(ol[:, L.RL_SENSOR]) == [0, 0, L.NZ_ANGLE]
    assert list(ol[:, L.RL_PULSE]) == [0, 1, 0]
    sb = noise_roles(HorizontalSearch(0.6354, loop=True).program()[0])
    assert list(sb[:, L.RL_JITTER]) == [L.JITTER_LATENCY, L.JITTER_LATENCY, L.JITTER_NONE]
    assert list(sb[:, L.RL_SENSOR]) == [L.NZ_HEIGHT, L.NZ_ENERGY, L.NZ_ANGLE]


def test_a_catch_on_a_bar_has_no_sensor_jitter_or_latency():
    """The hook meeting the bar is physics, not a controller acting on a sensed crossing:
    the row gets no noise role, though the row it leads to swaps (an actuation otherwise)."""
    gait = PhaseSequence([
        Segment("bar", value=0.0, direction="falling", bar_dx=0.34, bar_window=0.02,
                torque=0.5),
        Segment("time", value=0.2, magnets="swap", torque=0.3),
        Segment("free_end_height", direction="falling", torque=0.3),
        Segment("time", value=0.1, magnets="swap", next=0)], tick=0.001)
    roles = noise_roles(gait.program()[0])
    assert list(roles[:, L.RL_JITTER]) == [L.JITTER_NONE, L.JITTER_NONE, L.JITTER_LATENCY,
                                           L.JITTER_SHIFT]
    assert list(roles[:, L.RL_SENSOR]) == [0, 0, L.NZ_HEIGHT, 0]
    assert list(roles[:, L.RL_PULSE]) == [1, 1, 1, 0]


def test_a_runs_robot_draws_its_parameters_and_keeps_the_cg_on_the_link():
    robot = Robot.preset("seed2009")
    assert run_robot(robot, Noise(), 1, 0) is robot
    a = run_robot(robot, Noise(mass=0.1, com=0.4), 1, 0)
    b = run_robot(robot, Noise(mass=0.1, com=0.4), 1, 0)
    c = run_robot(robot, Noise(mass=0.1, com=0.4), 1, 1)
    assert a == b and a != c
    assert a.link1.mass != robot.link1.mass and a.link1.inertia == robot.link1.inertia
    for r in range(200):
        x = run_robot(robot, Noise(com=0.4), 2, r)
        assert 0.0 <= x.link1.com <= x.link1.length
    with pytest.raises(ValueError, match="timing"):
        Noise(timing=-1e-3)


# --- runs ----------------------------------------------------------------------------------------
def test_without_noise_a_run_is_the_deterministic_replay_bit_for_bit():
    """One compiled call per cycle continues exactly where the previous one stopped: cycle by
    cycle the same section state as one long open-loop run, until the same fall."""
    ref = _replay(40)
    assert ref.status == L.ST_FELL
    err = section_error(ref.section_state, REF)
    n = len(err)
    for k in (1, 7, n):
        r = _runs(Noise(), [0], max_cycles=k)
        assert r.cycles[0] == k and r.error[0] == err[k - 1]
        assert r.distance[0] == ref.section_state[k - 1][L.X]
    full = _runs(Noise(), [0, 1])
    assert list(full.cycles) == [n, n] and list(full.failure) == [L.ST_FELL] * 2


def test_runs_do_not_depend_on_how_they_are_grouped():
    noise = Noise(timing=2e-4, angle=1e-4, torque=0.02, mass=0.01, dtheta1=1e-3)
    together = _runs(noise, np.arange(6))
    apart = [_runs(noise, [r]) for r in (3, 0, 5, 1, 4, 2)]
    for k, r in zip((3, 0, 5, 1, 4, 2), apart):
        for field in ("cycles", "failure", "distance", "time", "error", "nfev"):
            assert getattr(r, field)[0] == getattr(together, field)[k], (k, field)
    # and the runs differ from one another (the noise is there)
    assert len(set(together.time)) > 1


def test_more_timing_jitter_shortens_the_open_loop_gait():
    few = _runs(Noise(timing=1e-5), np.arange(30), max_cycles=60)
    many = _runs(Noise(timing=2e-3), np.arange(30), max_cycles=60)
    assert np.all(few.failure != L.ST_OK) and np.all(many.failure != L.ST_OK)
    assert many.cycles.mean() < few.cycles.mean()


def test_the_error_bound_fails_a_run_at_the_first_cycle_beyond_it():
    ref = _replay(40)
    err = section_error(ref.section_state, REF)
    bound = 1e-2
    first = int(np.flatnonzero(err > bound)[0])            # 0-based cycle beyond the bound
    r = _runs(Noise(), [0], error_bound=bound)
    assert r.failure[0] == L.ST_ERROR_BOUND and r.cycles[0] == first


class _Program:
    """A controller given by its program table (what :func:`survival_runs` reads of one)."""

    def __init__(self, prog, obs, tick):
        self.prog, self.obs, self.tick, self.tick_phase = prog, obs, tick, 0.0

    def program(self):
        return self.prog.copy(), self.obs.copy()


def test_a_runs_latency_delays_every_actuation_by_its_one_draw():
    """Latency noise is one uniform draw per run on [0, scale), added to the delay of every
    magnet and motor action: the run equals, bit for bit, a noiseless run of the program
    with that delay written into its actuation rows."""
    from monkeystudy.kernel.noise import PER_RUN_CYCLE, standard_draw
    from monkeystudy.kernel.survival import LATENCY_SLOT

    scale, seed = 1e-3, 5
    prog, obs = _open_loop().program()
    actuation = noise_roles(prog)[:, L.RL_JITTER] != L.JITTER_NONE
    assert actuation.sum() >= 2                       # the swap and the motor's end
    for run in (0, 3):
        draw = standard_draw(seed, run, PER_RUN_CYCLE, LATENCY_SLOT, True)
        latency = scale * 0.5 * (draw + 1.0)
        assert 0.0 <= latency < scale
        delayed = prog.copy()
        delayed[actuation, L.S_DELAY] += latency
        noisy = _runs(Noise(latency=scale), [run], max_cycles=8)
        plain = survival_runs(_Program(delayed, obs, 0.001),
                              initial_state(GAIT["dtheta1"], GAIT["dtheta2"]), REF, runs=[run],
                              max_cycles=8, noise=Noise(), seed=seed, integrator=INTEG,
                              max_drop=0.61)
        for field in ("cycles", "failure", "distance", "time", "error", "height"):
            assert getattr(noisy, field)[0] == getattr(plain, field)[0], (run, field)
    a, b = (_runs(Noise(latency=scale), [r], max_cycles=8).time[0] for r in (0, 3))
    assert a != b                                     # each run draws its own


def test_the_height_is_the_attached_ends_height_where_the_last_cycle_is_measured():
    """Without noise, a run's height change after k cycles is the attached end's height at
    its k-th vertical crossing in one deterministic open-loop run."""
    from monkeystudy.simulation import run_controller

    res = run_controller(_open_loop(), initial_state(GAIT["dtheta1"], GAIT["dtheta2"]),
                         integrator=INTEG, cycles=12, max_drop=0.61)
    cross = res.log[res.log[:, L.L_KIND] == L.LOG_OBSERVER]
    for k in (1, 5, 12):
        r = _runs(Noise(), [0], max_cycles=k)
        assert r.cycles[0] == k
        assert r.height[0] == cross[k - 1, L.L_STATE + L.Y]
    assert _runs(Noise(), [0], max_cycles=12).height[0] != 0.0     # the replay drifts


def test_runs_counted_one_by_one_are_the_same_runs():
    """With a progress callback each run is counted as it ends (the runs then run one by
    one): the same numbers as all runs at once, bit for bit."""
    noise = Noise(timing=2e-3, mass=0.02)
    counted = []
    whole = _runs(noise, np.arange(5), max_cycles=12)
    one_by_one = _runs(noise, np.arange(5), max_cycles=12, progress=counted.append)
    assert counted == [1] * 5
    for field in ("cycles", "failure", "distance", "time", "error", "nfev", "height"):
        assert np.array_equal(getattr(whole, field), getattr(one_by_one, field)), field


def test_every_noise_source_is_a_field_of_noise_and_the_kernel_draws_its_slot():
    """SOURCES is Noise's fields (distribution aside), in order; the sources the kernel draws
    are exactly its noise vector's NZ_* slots, each set from its own field, and the others
    are drawn per run (run_robot; the robot has friction of every kind, so no draw is
    clipped at zero)."""
    from dataclasses import fields, replace

    from monkeystudy.analysis.survival import SOURCES
    from monkeystudy.robot import Friction

    assert [s.name for s in SOURCES] == [f.name for f in fields(Noise)
                                         if f.name != "distribution"]
    slots = {n[3:].lower() for n in dir(L) if n.startswith("NZ_") and n != "NZ_UNIFORM"}
    assert {s.name for s in SOURCES if s.in_kernel} == slots
    robot = replace(Robot.preset("seed2009"), pivot_friction=Friction(1.0, 1.0),
                    joint_friction=Friction(1.0, 1.0))
    for s in SOURCES:
        v = Noise(**{s.name: 0.25}).vector()
        assert v.sum() == (0.25 if s.in_kernel else 0.0), s.name
        if s.in_kernel:
            assert v[getattr(L, f"NZ_{s.name.upper()}")] == 0.25
        else:
            assert run_robot(robot, Noise(**{s.name: 0.25}), 1, 0) != robot, s.name


# --- a built robot on a ladder: friction drawn per run, the ladder's spacing ---------------------
def _bar_runs(noise, runs, max_cycles=4, robot=None, prog=None):
    """Runs of the two-swap bar brachiation of the identified AcroMonk model (tests/
    test_motor.py), from its fixed point, on its robot; ``prog`` replaces its program."""
    from monkeystudy.analysis.sections import cycle_section_state
    from test_bar_map import INTEG as BAR_INTEG, Z, bar_gait, bar_robot

    gait = bar_gait()
    controller = gait.loop_controller()
    if prog is not None:
        controller = _Program(prog, controller.program()[1], controller.tick)
    return survival_runs(controller, cycle_section_state(gait, Z), Z, runs=runs,
                         max_cycles=max_cycles, noise=noise, seed=11,
                         robot=robot or bar_robot(), integrator=BAR_INTEG,
                         section=gait.section_observers())


def test_a_runs_robot_keeps_the_rotor_and_the_motor():
    """Parameter noise redraws the links and nothing else: the motor's rotor and limits are
    the robot's."""
    from monkeystudy.robot import Motor, Rotor

    robot = Robot.preset("seed2009").with_rotor(Rotor(2.453e-4, 6.0, 1)).with_motor(
        Motor(3.0, 20.0))
    drawn = run_robot(robot, Noise(mass=0.01, inertia=0.01), 3, 0)
    assert drawn.link1.mass != robot.link1.mass
    assert drawn.rotor == robot.rotor and drawn.motor == robot.motor
    assert np.array_equal(drawn.params()[:, L.P_ROTOR:L.P_J22 + 1] != 0.0,
                          robot.params()[:, L.P_ROTOR:L.P_J22 + 1] != 0.0)


def test_a_runs_friction_is_drawn_about_the_robots_and_never_below_zero():
    """Friction noise is absolute: each run's coefficient is the robot's plus scale times its
    draw (Gaussian: the sample's spread is the scale), the same for the same run, clipped at
    zero; the links and the other coefficients are the robot's."""
    from dataclasses import replace

    from monkeystudy.robot import Friction

    robot = replace(Robot.preset("seed2009"), pivot_friction=Friction(0.0, 0.0786),
                    joint_friction=Friction(0.0414, 0.0))
    noise = Noise(pivot_coulomb=0.01, joint_viscous=0.0024)
    drawn = [run_robot(robot, noise, 7, r) for r in range(2000)]
    assert run_robot(robot, noise, 7, 5) == drawn[5] and drawn[5] != drawn[6]
    coulomb = np.array([d.pivot_friction.coulomb for d in drawn])
    viscous = np.array([d.joint_friction.viscous for d in drawn])
    assert np.mean(coulomb) == pytest.approx(0.0786, abs=3 * 0.01 / math.sqrt(2000))
    assert np.std(coulomb) == pytest.approx(0.01, rel=0.05)
    assert np.std(viscous) == pytest.approx(0.0024, rel=0.05)
    assert np.corrcoef(coulomb, viscous)[0, 1] == pytest.approx(0.0, abs=0.1)
    assert all(d.link1 == robot.link1 and d.link2 == robot.link2 for d in drawn)
    assert all(d.pivot_friction.viscous == 0.0 and d.joint_friction.coulomb == 0.0
               for d in drawn)
    wide = [run_robot(robot, Noise(pivot_coulomb=0.134), 7, r).pivot_friction.coulomb
            for r in range(400)]
    assert min(wide) == 0.0 and 0.0 < max(wide)       # about 28 % of the draws clip


def test_a_runs_friction_noise_is_a_noiseless_run_of_its_robot():
    """The kernel sees a friction draw only through the run's robot: a run under friction
    noise is, bit for bit, the noiseless run of the robot drawn for it; a zero scale is no
    noise at all, bit for bit."""
    from test_bar_map import bar_robot

    noise = Noise(pivot_coulomb=2e-4, joint_viscous=2e-5)
    for run in (0, 3):
        noisy = _bar_runs(noise, [run])
        plain = _bar_runs(Noise(), [run], robot=run_robot(bar_robot(), noise, 11, run))
        for field in ("cycles", "failure", "distance", "time", "error", "height", "nfev"):
            assert getattr(noisy, field)[0] == getattr(plain, field)[0], (run, field)
    a, b = (_bar_runs(noise, [r]).error[0] for r in (0, 3))
    assert a != b
    zero = _bar_runs(Noise(pivot_coulomb=0.0, joint_viscous=0.0, bar_spacing=0.0), [0, 1])
    none = _bar_runs(Noise(), [0, 1])
    for field in ("cycles", "failure", "distance", "time", "error", "height", "nfev"):
        assert np.array_equal(getattr(zero, field), getattr(none, field)), field


def test_the_ladders_spacing_moves_every_bar_of_a_run_by_its_one_draw():
    """Bar-spacing noise is one draw per run, added to every bar's distance from the end the
    robot hangs from: the run equals, bit for bit, a noiseless run of the program with its
    bars that much farther; as every catch snaps onto its bar, the attached end has
    travelled exactly two bars per cycle, 2 (0.34 m + e)."""
    from monkeystudy.kernel.noise import PER_RUN_CYCLE, standard_draw
    from monkeystudy.kernel.survival import BAR_SPACING_SLOT
    from test_bar_map import bar_gait

    scale, cycles = 1e-3, 4
    prog = bar_gait().loop_controller().program()[0]
    bars = prog[:, L.S_GUARD] == L.G_BAR
    assert bars.sum() == 2 and np.all(prog[bars, L.S_BAR_DX] == -0.34)
    for run in (0, 3):
        e = scale * standard_draw(11, run, PER_RUN_CYCLE, BAR_SPACING_SLOT, False)
        wider = prog.copy()
        wider[bars, L.S_BAR_DX] -= e
        noisy = _bar_runs(Noise(bar_spacing=scale), [run], max_cycles=cycles)
        plain = _bar_runs(Noise(), [run], max_cycles=cycles, prog=wider)
        assert noisy.cycles[0] == cycles
        for field in ("cycles", "failure", "distance", "time", "error", "height"):
            assert getattr(noisy, field)[0] == getattr(plain, field)[0], (run, field)
        assert noisy.distance[0] == pytest.approx(-2 * cycles * (0.34 + e), abs=1e-12)
    a, b = (_bar_runs(Noise(bar_spacing=scale), [r]).distance[0] for r in (0, 3))
    assert a != b


def test_catches_per_cycle_counts_a_cycles_bar_catches():
    from monkeystudy.analysis.survival import catches_per_cycle
    from test_bar_map import bar_gait

    assert catches_per_cycle(bar_gait().loop_controller().program()[0]) == 2
    assert catches_per_cycle(_open_loop().program()[0]) == 0
    prog = _open_loop().program()[0].copy()
    prog[:, L.S_CYCLE] = 0.0
    with pytest.raises(ValueError, match="no cycle-ending row"):
        catches_per_cycle(prog)
