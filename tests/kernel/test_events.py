"""Event detection and location in the hybrid loop (``kernel/events.py``, ``kernel/hybrid.py``).

* A guard that crosses zero and back within one step (the grazing swap) is found: scipy's
  ``solve_ivp``, which takes exactly the kernel's steps, steps over it.
* A guard already zero when a segment starts does not fire there.
* With a controller tick, a located crossing is acted on at the first tick at or after it, and
  only if the condition still holds there; time guards end steps exactly.
* Observers and trajectory samples never change the steps taken.
"""
import json
import math
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from monkeystudy import (
    HorizontalSearch, Integrator, Observer, OpenLoop, PhaseSequence, Segment,
    evaluate_horizontal_gait, initial_state, run_controller,
)
from monkeystudy.kernel import dynamics as dyn
from monkeystudy.kernel import events as ev
from monkeystudy.kernel.layout import (
    G_COORD, G_ENERGY_RESTORED, G_FREE_END_HEIGHT, K_REJECTED, K_STEPS, L_ID, L_KIND, L_STATE,
    L_T, LOG_OBSERVER, LOG_SEGMENT, ST_END_TIME, ST_HORIZON, ST_OK,
)
from reference import model as ref_model

from .helpers import ROBOTS, grazing_point, reference_robot

pytestmark = pytest.mark.nojit

FM = np.array([1.0, 1.0])
TAU = 0.6354


def _scipy_first_swap(d1, d2, rtol):
    """scipy's own event detection of the swap guard, on the kernel's vector field."""
    p = ROBOTS["seed2009"].params()[0]

    def f(t, y):
        dy = np.empty(4)
        dyn.rhs_swing(p, 0.0, FM, y, dy)
        return dy

    def height(t, y):
        return -p[2] * math.cos(y[0]) - p[3] * math.cos(y[0] + y[1])
    height.terminal = True
    height.direction = 1
    sol = solve_ivp(f, (0.0, 3.0), [0.0, 0.0, d1, d2], method="DOP853", rtol=rtol, atol=rtol,
                    events=[height])
    return sol.t_events[0][0] if len(sol.t_events[0]) else math.inf


@pytest.mark.parametrize("delta", [1e-5, 1e-6, 1e-7])
@pytest.mark.parametrize("rtol", [1e-13, 1e-10, 1e-8])
def test_double_crossing_within_one_step(delta, rtol):
    """B rises ``delta`` above A for a moment (the two crossings ~sqrt(delta) apart, far inside
    one step): the kernel swaps at the first crossing; scipy's events miss it."""
    d1, d2 = grazing_point("seed2009", (0.0, 1.0), delta)
    ref = reference_robot("seed2009")
    t_max, _ = ref_model.first_height_maximum(ref, d1, d2)
    exact = ref_model.horizontal_gait(ref, d1, d2, TAU)
    t_up = exact.t_switch
    t_down = 2 * t_max - t_up                  # the excursion is symmetric to first order
    assert t_up < t_max
    # scipy takes the kernel's steps (test_integrate) and compares signs at step ends only:
    # the whole excursion lies inside one step
    assert _scipy_first_swap(d1, d2, rtol) > t_max + 0.5
    big = evaluate_horizontal_gait(d1, d2, torque=TAU, integrator=Integrator("dop853", rtol,
                                                                             rtol))
    assert big.status == ST_OK
    assert t_up - 0.05 * (t_down - t_up) < big.t_switch < t_max
    if rtol == 1e-13:
        assert abs(big.t_switch - t_up) <= 1e-9
    # small steps: the crossing is bracketed by step ends
    small = evaluate_horizontal_gait(d1, d2, torque=TAU,
                                     integrator=Integrator("dop853", rtol, rtol, max_step=1e-4))
    assert small.status == ST_OK
    assert abs(small.t_switch - t_up) <= max(1e-9, 1e3 * rtol)


def test_grazing_excursion_between_ticks_is_not_acted_on():
    """With a 1 ms tick, an excursion of B above A that starts and ends between two ticks is
    not acted on (the condition no longer holds at the tick); one containing a tick is, at
    that tick. Both as the reference's ticked controller."""
    d1, d2 = grazing_point("seed2009", (0.0, 1.0), 1e-7)
    ref = reference_robot("seed2009")
    t_max, _ = ref_model.first_height_maximum(ref, d1, d2)
    t_up = ref_model.horizontal_gait(ref, d1, d2, TAU).t_switch
    t_down = 2 * t_max - t_up
    tick = 1e-3
    assert t_down - t_up < 0.8 * tick
    integ = Integrator("dop853", 1e-13, 1e-13)
    # a tick inside the excursion
    phase_in = math.fmod(0.5 * (t_up + t_max), tick)
    k = evaluate_horizontal_gait(d1, d2, torque=TAU, tick=tick, tick_phase=phase_in,
                                 integrator=integ)
    assert k.t_switch == pytest.approx(0.5 * (t_up + t_max), abs=1e-12)
    # ticks only outside it: the next tick after t_up comes after t_down
    phase_out = math.fmod(t_down + 0.1 * tick, tick)
    k = evaluate_horizontal_gait(d1, d2, torque=TAU, tick=tick, tick_phase=phase_out,
                                 integrator=integ)
    assert k.t_switch > t_down + 0.5
    # the reference's ticked controller (its tick grid starts at 0: shift time by the phase)
    g = _ticked_reference_swap(ref, d1, d2, tick, phase_out)
    assert k.t_switch == pytest.approx(g, abs=1e-9)


def _ticked_reference_swap(ref, d1, d2, tick, phase):
    height = lambda y: ref.free_end_height(y[0], y[1])  # noqa: E731
    rate = lambda y: (ref.L1 * math.sin(y[0]) * y[2]  # noqa: E731
                      + ref.L2 * math.sin(y[0] + y[1]) * (y[2] + y[3]))
    # the reference ticks at multiples of tick from 0: start the clock at -phase
    seg = ref_model.run_segment(ref.swing_rhs(0.0), -phase, [0.0, 0.0, d1, d2], height, +1,
                                horizon=3.0, rtol=1e-13, atol=1e-13, tick=tick, rate=rate)
    return seg.t + phase


# ----------------------------------------------------------------------------------------------
# a guard already zero at a segment start
# ----------------------------------------------------------------------------------------------
def test_zero_guard_at_segment_start_does_not_fire():
    """Two segments each ending when theta1 crosses 0: the second starts exactly on its guard
    and must end at the *next* crossing (those of an observer on an uninterrupted run)."""
    start = initial_state(2.0, -3.0, theta1=0.4)
    integ = Integrator("dop853", 1e-12, 1e-12)
    seg = Segment("coord", coord="theta1", value=0.0, direction="either", ticked=False)
    res = run_controller(PhaseSequence([seg, seg, seg], observers=()), start,
                         robot="seed2009", integrator=integ)
    assert res.status == ST_OK
    obs = run_controller(PhaseSequence([Segment("none")],
                                       observers=[Observer("coord", "theta1", 0.0, "either")]),
                         start, robot="seed2009", t_end=5.0,
                         integrator=Integrator("dop853", 1e-12, 1e-12, max_time=10.0))
    crossings = obs.log[obs.log[:, L_KIND] == LOG_OBSERVER, L_T]
    assert len(crossings) >= 3
    np.testing.assert_allclose(res.segment_times, crossings[:3], rtol=0, atol=1e-9)
    assert np.all(np.diff(res.segment_times) > 0.05)


def test_swap_at_height_does_not_retrigger():
    """After a swap, the new free end (A) is exactly at the new pivot's height: a following
    "free end at the attached end's height" segment must wait for the next rise of A."""
    integ = Integrator("dop853", 1e-12, 1e-12)
    prog = PhaseSequence([
        Segment("free_end_height", direction="rising", ticked=False),
        Segment("free_end_height", direction="rising", magnets="swap", ticked=False),
    ], observers=())
    res = run_controller(prog, initial_state(0.902, 10.935), robot="seed2009",
                         integrator=integ)
    assert res.status == ST_OK
    t0, t1 = res.segment_times
    assert t1 - t0 > 0.05
    rows = res.log[res.log[:, L_KIND] == LOG_SEGMENT]
    par = ROBOTS["seed2009"].params()
    s = rows[1, L_STATE:L_STATE + 8]      # end of segment 1, in the flipped frame
    dy = dyn.free_end_offset(par[1], s[2], s[3])[1]
    assert abs(dy) <= 1e-12


# ----------------------------------------------------------------------------------------------
# ticks and time guards
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("tick_phase", [0.0, 3.7e-4])
def test_ticked_state_guard_acts_at_next_tick(tick_phase):
    start = initial_state(1.5, 4.0)
    seg = Segment("coord", coord="theta1", value=0.3, direction="rising", ticked=True)
    exact = run_controller(PhaseSequence([seg], observers=()), start,
                           integrator=Integrator("dop853", 1e-12, 1e-12))
    ticked = run_controller(PhaseSequence([seg], observers=(), tick=1e-3,
                                          tick_phase=tick_phase), start,
                            integrator=Integrator("dop853", 1e-12, 1e-12))
    te, tt = exact.segment_times[0], ticked.segment_times[0]
    k = (tt - tick_phase) / 1e-3
    assert abs(k - round(k)) < 1e-9
    assert te <= tt < te + 1e-3
    assert ticked.state[2] > 0.3        # the condition holds at the tick


_ON_TICK_SCRIPT = textwrap.dedent("""
    import json, math, sys
    from monkeystudy import Integrator, PhaseSequence, Segment, initial_state, run_controller
    start = initial_state(1.5, 4.0)
    seg = Segment("coord", coord="theta1", value=0.3, direction="rising", ticked=True)
    integ = Integrator("dop853", 1e-12, 1e-12)
    tc = run_controller(PhaseSequence([seg], observers=()), start,
                        integrator=integ).segment_times[0]
    out = []
    for off in json.loads(sys.argv[1]):
        phase = math.fmod(tc - off, 1e-3)
        r = run_controller(PhaseSequence([seg], observers=(), tick=1e-3, tick_phase=phase),
                           start, integrator=integ)
        out.append([off, int(r.status), r.segment_times[0], phase])
        print(json.dumps([tc, out]), flush=True)
""")


def test_crossing_on_a_tick_is_acted_on():
    """Named fixture: a crossing exactly on a tick, or within the tick grid's round-off snap
    after one. The first tick "at or after" the crossing is then the crossing itself; the loop
    used to check the condition a hair before the root, fail, find the same root again and
    spin forever. Run in a subprocess so that a regression fails instead of hanging."""
    offsets = [0.0, 1e-13, 5e-13, -1e-13, 2e-12]
    r = subprocess.run([sys.executable, "-c", _ON_TICK_SCRIPT, json.dumps(offsets)],
                       cwd=Path(__file__).resolve().parents[2], capture_output=True, text=True,
                       timeout=900)
    assert r.returncode == 0, r.stderr[-2000:]
    tc, out = json.loads(r.stdout.strip().splitlines()[-1])
    assert len(out) == len(offsets), out
    for off, status, t_exit, phase in out:
        assert status == ST_OK
        k = (t_exit - phase) / 1e-3
        assert abs(k - round(k)) < 1e-9               # on the tick grid
        if off >= 0.0 and off <= 1e-12:               # the tick is the crossing (snapped)
            assert abs(t_exit - tc) <= 1e-12
        elif off < 0.0:                               # the tick just after the crossing
            assert t_exit == pytest.approx(tc - off, abs=1e-15)
        else:                                         # the tick just before: the next one
            assert t_exit == pytest.approx(tc - off + 1e-3, abs=1e-12)


@pytest.mark.parametrize("tick", [1e-3, 0.01, 0.05, 0.2])
@pytest.mark.parametrize("coord,value,direction", [
    ("theta1", 0.3, "rising"), ("theta1", 0.0, "either"), ("theta2", -0.5, "falling"),
    ("theta1", 0.57, "rising"),   # 6 mrad below its peak: above for ~50 ms only
])
def test_ticked_guards_match_reference(tick, coord, value, direction):
    """A ticked coordinate guard, ticks from 1 ms (acted on in the crossing's step) to 0.2 s
    (the tick in a later step, or the condition gone by then and the search going on),
    against the reference's ticked segment."""
    robot = ROBOTS["asymmetric"]
    ref = reference_robot("asymmetric")
    y0 = [0.1, 0.2, 2.5, -4.0]
    idx = {"theta1": 0, "theta2": 1}[coord]
    dirn = {"rising": 1, "falling": -1, "either": 0}[direction]
    seg = Segment("coord", coord=coord, value=value, direction=direction, ticked=True)
    res = run_controller(PhaseSequence([seg], observers=(), tick=tick, tick_phase=0.0),
                         initial_state(y0[2], y0[3], theta1=y0[0], theta2=y0[1]), robot=robot,
                         integrator=Integrator("dop853", 1e-13, 1e-13))
    want = ref_model.run_segment(ref.swing_rhs(0.0), 0.0, y0, lambda y: y[idx] - value, dirn,
                                 horizon=3.0, rtol=1e-13, atol=1e-13, tick=tick)
    if math.isnan(want.t):        # each excursion over before its tick: never acted on
        assert res.status == ST_HORIZON and math.isnan(res.segment_times[0])
        return
    assert res.status == ST_OK
    assert res.segment_times[0] == pytest.approx(want.t, abs=1e-9)
    np.testing.assert_allclose(res.state[[2, 3, 6, 7]], want.y, rtol=0, atol=1e-9)


@pytest.mark.parametrize("tick", [0.0, 1e-3])
def test_time_guards_are_step_bounds(tick):
    """OpenLoop's swap and motor-off times: exact, or the first tick at or after them."""
    ts, tm = 0.42766, 0.02531
    res = run_controller(OpenLoop(ts, tm, TAU, tick=tick), initial_state(0.902, 10.935),
                         robot="seed2009", cycles=1)
    if tick == 0.0:
        assert res.segment_times[0] == ts
        assert res.segment_times[1] == ts + tm
    else:
        assert res.segment_times[0] == pytest.approx(0.428, abs=1e-15)
        assert res.segment_times[1] == pytest.approx(0.453, abs=1e-15)


# ----------------------------------------------------------------------------------------------
# observers
# ----------------------------------------------------------------------------------------------
def test_observers_and_samples_do_not_change_the_steps():
    start = initial_state(0.902, 10.935)
    integ = Integrator("dop853", 1e-10, 1e-12)
    plain = run_controller(HorizontalSearch(TAU), start, integrator=integ)
    observers = [Observer("coord", "theta1", 0.0, "either"),
                 Observer("coord", "theta2", 1.0, "either"),
                 Observer("free_end_height", direction="rising")]
    busy = run_controller(PhaseSequence(HorizontalSearch(TAU).segments(), observers=observers),
                          start, integrator=integ, sample_dt=1e-3)
    assert plain.status == busy.status == ST_OK
    assert plain.counts[K_STEPS] == busy.counts[K_STEPS]
    assert plain.counts[K_REJECTED] == busy.counts[K_REJECTED]
    np.testing.assert_array_equal(plain.state, busy.state)
    np.testing.assert_array_equal(plain.segment_times, busy.segment_times)
    assert np.sum(busy.log[:, L_KIND] == LOG_OBSERVER) > 0


@pytest.mark.parametrize("name", ["seed2009", "asymmetric"])
def test_observer_crossings_match_scipy_events(name):
    """Every crossing of theta1 = 0 and of theta2 = 1 over 4 s of swinging, logged by
    observers, against scipy's (non-terminal) events on the reference model."""
    robot = ROBOTS[name]
    ref = reference_robot(name)
    y0 = [0.2, -0.1, 3.0, -5.0]
    obs = [Observer("coord", "theta1", 0.0, "either"), Observer("coord", "theta2", 1.0, "either")]
    res = run_controller(PhaseSequence([Segment("none")], observers=obs),
                         initial_state(y0[2], y0[3], theta1=y0[0], theta2=y0[1]), robot=robot,
                         integrator=Integrator("dop853", 1e-13, 1e-13, max_time=10.0),
                         t_end=4.0)
    assert res.status == ST_END_TIME
    ev1 = lambda t, y: y[0]  # noqa: E731
    ev2 = lambda t, y: y[1] - 1.0  # noqa: E731
    sol = solve_ivp(ref.swing_rhs(0.0), (0.0, 4.0), y0, method="DOP853", rtol=1e-13,
                    atol=1e-13, events=[ev1, ev2])
    rows = res.log[res.log[:, L_KIND] == LOG_OBSERVER]
    for k in range(2):
        got = rows[rows[:, L_ID] == k, L_T]
        want = sol.t_events[k]
        assert len(got) == len(want) and len(got) >= 3
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
        # the logged state satisfies the observer's guard
        vals = rows[rows[:, L_ID] == k, L_STATE + 2 + k] - (0.0, 1.0)[k]
        assert np.max(np.abs(vals)) <= 1e-12


# ----------------------------------------------------------------------------------------------
# the cubic Hermite screen: which steps are searched on the dense output
# ----------------------------------------------------------------------------------------------
def _screen_cases(rng, n, h_omega_max):
    """Steps of smooth guards (sinusoids, a two-tone sum, a Gaussian bump) whose interior
    extremum lies near zero; yields ``(ga, ra, gb, rb, h, samples)``."""
    shapes = [
        (lambda x: np.cos(x), lambda x: -np.sin(x)),
        (lambda x: np.cos(x) + 0.3 * np.cos(2.7 * x + 0.4),
         lambda x: -np.sin(x) - 0.81 * np.sin(2.7 * x + 0.4)),
        (lambda x: np.exp(-x * x), lambda x: -2.0 * x * np.exp(-x * x)),
    ]
    for _ in range(n):
        f, fp = shapes[rng.integers(len(shapes))]
        h = rng.uniform(0.02, h_omega_max)
        t0 = rng.uniform(-3.0, 3.0)
        g = f(np.linspace(t0, t0 + h, 401))
        k = np.argmax(np.abs(g - 0.5 * (g[0] + g[-1])))
        if k in (0, 400):
            continue
        variation = abs(g[k] - g[0]) + abs(g[k] - g[-1])
        g = g - (g[k] + rng.uniform(-1.0, 1.0) * 0.5 * variation)  # extremum near zero
        yield g[0], fp(t0), g[-1], fp(t0 + h), h, g


def test_screen_flags_every_excursion_across_zero_on_resolved_steps():
    """Whenever a smooth guard crosses zero and back inside a step (same-signed ends), the
    screen flags the step, for steps up to 2 rad of the guard's phase (a swing period in
    three steps; the study's steps are ~0.05-0.3 rad)."""
    rng = np.random.default_rng(11)
    crossings = 0
    for ga, ra, gb, rb, h, g in _screen_cases(rng, 6000, 2.0):
        for direction in (1.0, -1.0, 0.0):
            if ev.crosses(ga, gb, direction):
                continue
            if any(ev.crosses(g[k], g[k + 1], direction) for k in range(len(g) - 1)):
                crossings += 1
                assert ev.hermite_flags(ga, ra, gb, rb, h, direction), (ga, ra, gb, rb, h)
    assert crossings > 500


def test_screen_skips_extrema_far_from_zero():
    """A turning point well away from zero (a swing's apex below the attached end) is not
    searched; one within the margin, or whose model crosses, is."""
    h = 0.1
    # g = -1 + 0.5 cos(t) around its maximum at t = 0.05: variation ~1e-3, value ~-0.5
    t = np.array([0.0, h]) - 0.05
    g = -1.0 + 0.5 * np.cos(t)
    r = -0.5 * np.sin(t)
    assert r[0] * r[1] < 0.0
    assert not ev.hermite_flags(g[0], r[0], g[1], r[1], h, 1.0)
    variation = 2 * (0.5 - 0.5 * math.cos(0.05))
    top = 0.5 - 1.0  # the maximum's value
    # the same turning point moved to lie within the margin below and above zero, and to
    # straddle it (the model crosses)
    for peak in (-0.5 * ev.GRAZE_MARGIN * variation, 0.5 * ev.GRAZE_MARGIN * variation,
                 0.25 * variation):
        shift = peak - top
        assert ev.hermite_flags(g[0] + shift, r[0], g[1] + shift, r[1], h, 1.0), peak
    # and farther below zero than the margin
    shift = -2.0 * ev.GRAZE_MARGIN * variation - top
    assert not ev.hermite_flags(g[0] + shift, r[0], g[1] + shift, r[1], h, 1.0)


def test_hermite_root_estimate_solves_the_monotone_cubic():
    """The root estimate seeding the dense-output Newton search is the cubic model's root."""
    rng = np.random.default_rng(5)
    checked = 0
    for _ in range(2000):
        ga, gb = -rng.uniform(1e-6, 1.0), rng.uniform(1e-6, 1.0)
        da, db = rng.uniform(0.0, 3.0, 2) * (gb - ga)
        if rng.random() < 0.5:
            ga, gb, da, db = -ga, -gb, -da, -db
        if not ev.hermite_monotone(ga, da, gb, db, 1.0):
            continue
        s = ev._hermite_root(ga, da, gb, db)
        coeffs = [2 * ga + da - 2 * gb + db, -3 * ga - 2 * da + 3 * gb - db, da, ga]
        want = [r.real for r in np.roots(coeffs) if abs(r.imag) < 1e-9 and -1e-9 <= r.real <= 1 + 1e-9]
        assert len(want) == 1
        assert s == pytest.approx(want[0], abs=1e-11)
        checked += 1
    assert checked > 1000


def _swing_steps(d1, d2, tau, rtol):
    p = ROBOTS["seed2009"].params()[0]

    def f(t, y):
        dy = np.empty(4)
        dyn.rhs_swing(p, tau, FM, y, dy)
        return dy
    # scipy's DOP853 takes the kernel's steps (test_integrate) and has its dense output
    return p, solve_ivp(f, (0.0, 3.0), [0.0, 0.0, d1, d2], method="DOP853", rtol=rtol,
                        atol=rtol * 1e-2, dense_output=True)


@pytest.mark.parametrize("rtol", [1e-3, 1e-6, 1e-10])
def test_screen_margin_covers_the_cubic_models_error_on_the_studys_swings(rtol):
    """On swings from the study's valley and around it, wherever the swap guard (free end's
    height), the energy-restored guard (motor on) or theta1 turns inside a step, the cubic
    model's extremum value is within an eighth of ``GRAZE_MARGIN`` times the model's
    variation of the dense output's: the screen's margin holds with a factor of 8 to spare."""
    pivot = np.zeros(2)
    work = np.zeros(8)
    worst = 0.0
    turns = 0
    for d1 in (0.5, 1.0, 1.6, 2.5):
        for d2 in (2.0, 6.0, 10.0, 12.0, 15.0):
            for kind, index, tau in ((G_FREE_END_HEIGHT, 0, 0.0), (G_ENERGY_RESTORED, 0, TAU),
                                     (G_COORD, 2, 0.0)):
                p, sol = _swing_steps(d1, d2, tau, rtol)
                eref = dyn.total_energy8(p, np.array([0.0, 0, 0, 0, 0, 0, d1, d2]))

                def g_r(y):
                    return (ev.guard(kind, index, 0.0, 0, p, tau, FM, y, pivot, eref),
                            ev.guard_rate(kind, index, 0, p, tau, FM, y, pivot, work))
                for i in range(len(sol.t) - 1):
                    ga, ra = g_r(sol.y[:, i])
                    gb, rb = g_r(sol.y[:, i + 1])
                    h = sol.t[i + 1] - sol.t[i]
                    if ra * rb >= 0.0:
                        continue
                    n, s1, _ = ev._hermite_extrema(ga, ra, gb, rb, h)
                    assert n == 1
                    gs = ev._hermite_value(s1, ga, h * ra, gb, h * rb)
                    ts = np.linspace(sol.t[i], sol.t[i + 1], 4001)
                    gd = np.array([g_r(y)[0] for y in sol.sol(ts).T])
                    ge = gd[np.argmax(np.abs(gd - 0.5 * (ga + gb)))]
                    worst = max(worst, abs(ge - gs) / (abs(gs - ga) + abs(gs - gb)))
                    turns += 1
    assert turns >= 100
    assert worst <= ev.GRAZE_MARGIN / 8, worst
