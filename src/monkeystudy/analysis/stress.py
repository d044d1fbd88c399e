"""Numerical stress scenarios: energy drift, long runs, extreme parameters.

Plain numpy in, plain numpy out, like :mod:`monkeystudy.analysis` and
:mod:`monkeystudy.precision`; the study step ``stress`` (:mod:`monkeystudy.study`) runs them
as tasks and labels the results (docs/datasets.md, ``stress``). Everything here is
deterministic: no wall-clock time is measured, so the results are bit-reproducible.

* :func:`energy_drift` - relative energy error of an unforced, frictionless run (docs/model.md
  section 3: energy is conserved in swing and in flight) at log-spaced checkpoints, its
  growth exponent (:func:`growth_exponent`) and the drift per reference period
  (:func:`reference_period`).
* :func:`long_run` - a controller run for many cycles: it must stop with a status (ok, fell,
  ...), never an exception, and within its step budget.
* :func:`extreme_case` - gait evaluations (or a free run with Coulomb friction) of a robot
  with extreme parameters (:data:`EXTREME_CASES`): status counts and whether every result
  marked ok is finite.
"""
from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from ..controllers import HorizontalSearch, Integrator, OpenLoop, PhaseSequence, Segment
from ..kernel import layout as L
from ..kernel.dynamics import kinetic_energy, potential_energy
from ..robot import Friction, Link, Robot
from ..simulation import evaluate_gaits, initial_state, run_controller

#: an unforced run: no segment guard, no observers (only ``t_end`` stops it)
FREE = PhaseSequence([Segment("none")], ())

#: phases of the energy-drift runs
DRIFT_PHASES = ("swing", "flight")

#: swing start: hanging from end A, (dtheta1, dtheta2) = (1, 0) rad s-1 - a regular,
#: small-amplitude swing (|theta1| < 0.26 rad) of period ~1.6 s for seed2009
SWING_START = {"dtheta1": 1.0, "dtheta2": 0.0}

#: flight start (tests/stress/test_stress.py): tumbling free fall, end A at (0, 0) moving
#: at (1, 2) m s-1
FLIGHT_START = {"dtheta1": 3.0, "dtheta2": -5.0, "theta1": 0.4, "theta2": 0.8,
                "dx": 1.0, "dy": 2.0}

#: window [s] and tolerance of the short sampled run that measures the reference period
PERIOD_WINDOW = 60.0
PERIOD_SAMPLE_DT = 1e-3
PERIOD_RTOL = 1e-10

#: drift values at or below this are round-off (100 double-precision epsilons): the growth
#: exponent is fitted only above it
DRIFT_FLOOR = 100.0 * float(np.finfo(float).eps)

#: the extreme cases, in their dataset order, with a one-line description
EXTREME_CASES = {
    "mass_ratio_1_100": "link masses 1 : 100 kg (I 0.03 : 3 kg m2, CG mid-link)",
    "mass_ratio_100_1": "link masses 100 : 1 kg (I 3 : 0.03 kg m2, CG mid-link)",
    "tiny_inertia": "both links' inertia 1e-8 kg m2 (point masses at mid-link)",
    "cg_at_the_ends": "link 1's CG at end A, link 2's at end B",
    "huge_velocities": "the study's robot started at |dtheta| = 1e3 rad s-1",
    "coulomb_sticking": "the study's robot with friction pivot {viscous 0.01 N m s, coulomb "
                        "0.3 N m}, joint {0.01, 0.2}: a free 20 s run that sticks",
}

#: starts [rad s-1] of the huge_velocities case (all four sign combinations of 1e3 rad s-1)
HUGE_VELOCITIES = ((1e3, -1e3), (1e3, 1e3), (-1e3, 1e3), (-1e3, -1e3))

#: friction of the coulomb_sticking case (pivot, joint) and its free run's start and length
COULOMB_FRICTION = (Friction(0.01, 0.3), Friction(0.01, 0.2))
COULOMB_START = (2.0, 1.0)
COULOMB_T_END = 20.0


# --- energy drift ------------------------------------------------------------------------------
def frictionless(robot: Robot) -> Robot:
    """The robot without friction (energy is conserved only then)."""
    return replace(robot, pivot_friction=Friction(), joint_friction=Friction())


def drift_start(phase: str) -> np.ndarray:
    """Hybrid start state of an energy-drift run: ``swing`` (:data:`SWING_START`) or
    ``flight`` (:data:`FLIGHT_START`, nothing attached)."""
    if phase == "swing":
        return initial_state(**SWING_START)
    if phase == "flight":
        s = FLIGHT_START
        hyb = initial_state(s["dtheta1"], s["dtheta2"], theta1=s["theta1"],
                            theta2=s["theta2"])
        hyb[L.H_PHASE] = L.PHASE_FLIGHT
        hyb[L.DX], hyb[L.DY] = s["dx"], s["dy"]
        return hyb
    raise ValueError(f"phase must be one of {DRIFT_PHASES}, got {phase!r}")


def energy_parts(par: np.ndarray, hyb: np.ndarray) -> tuple[float, float]:
    """Kinetic and potential energy [J] (world frame, docs/model.md section 1) of a hybrid state."""
    p = par[int(hyb[L.H_FLIPPED])]
    s = hyb
    return (kinetic_energy(p, s[2], s[3], s[4], s[5], s[6], s[7]),
            potential_energy(p, s[1], s[2], s[3]))


def reference_period(robot: Robot, state: np.ndarray, *, method: str = "dop853") -> float:
    """The time unit [s] of a drift run: from a :data:`PERIOD_WINDOW` s run sampled every
    :data:`PERIOD_SAMPLE_DT` s, the mean interval between rising crossings of theta1 = 0
    (linearly interpolated) when there are at least three (an oscillation), else
    ``2 pi / |mean dtheta1/dt|`` (link 1 tumbling); the window itself if theta1 does neither.
    """
    res = run_controller(FREE, state, robot=robot, t_end=state[L.H_T] + PERIOD_WINDOW,
                         sample_dt=PERIOD_SAMPLE_DT, log_capacity=0,
                         integrator=Integrator(method=method, rtol=PERIOD_RTOL,
                                               atol=PERIOD_RTOL * 1e-2, max_time=1e9))
    t, th = res.sample_t, res.sample_state[:, L.TH1]
    up = np.flatnonzero((th[:-1] < 0.0) & (th[1:] >= 0.0))
    if up.size >= 3:
        tc = t[up] - th[up] * (t[up + 1] - t[up]) / (th[up + 1] - th[up])
        return float(np.mean(np.diff(tc)))
    turn = abs(th[-1] - th[0])
    span = t[-1] - t[0]
    return float(2.0 * math.pi * span / turn) if turn > 2.0 * math.pi else float(span)


def checkpoint_times(period: float, periods: float, n: int) -> np.ndarray:
    """``n`` log-spaced times [s] from one to ``periods`` reference periods."""
    return period * np.geomspace(1.0, float(periods), int(n))


def growth_exponent(t, drift, floor: float = DRIFT_FLOOR) -> float:
    """Log-log slope of ``drift`` against ``t`` over the last decade of checkpoints (``t >=
    t[-1] / 10``), fitted on the values above ``floor`` (round-off); NaN when fewer than
    three remain. 1 is linear growth (a non-symplectic integrator's bias), 0.5 a random walk,
    0 or less no growth."""
    t = np.asarray(t, float)
    d = np.asarray(drift, float)
    with np.errstate(invalid="ignore"):
        use = (t >= t[-1] / 10.0 * (1.0 - 1e-12)) & np.isfinite(d) & (d > floor)
    if int(use.sum()) < 3:
        return math.nan
    return float(np.polyfit(np.log(t[use]), np.log(d[use]), 1)[0])


def energy_drift(robot: Robot, phase: str, *, rtol: float, periods: float, checkpoints: int,
                 atol_ratio: float = 1e-2, method: str = "dop853") -> dict[str, Any]:
    """Relative energy drift of an unforced, frictionless run of ``phase`` at ``checkpoints``
    log-spaced times from one to ``periods`` reference periods (:func:`reference_period`).

    The run continues from checkpoint to checkpoint (``run_controller`` with ``t_end``, an
    unbounded phase horizon); at each the drift is ``|E - E0| / (|K| + |V|)``: integration
    errors scale with the state (``rtol |y|``), and in a long free fall K and V each grow
    far beyond their nearly constant sum, so the drift is judged against the energy
    exchanged (for the swing ``|K| + |V|`` stays within ~10 % of ``|E0|``).

    Returns ``period`` [s], ``time`` [s], ``drift`` [1], ``growth_exponent``,
    ``drift_per_period`` (final drift / ``periods``), ``steps`` and ``status`` (of the last
    leg; END_TIME when every leg reached its checkpoint), ``energy0`` [J].
    """
    robot = frictionless(robot)
    par = robot.params()
    state = drift_start(phase)
    period = reference_period(robot, state, method=method)
    times = checkpoint_times(period, periods, checkpoints)
    k0, v0 = energy_parts(par, state)
    e0 = k0 + v0
    integ = Integrator(method=method, rtol=rtol, atol=rtol * atol_ratio, max_time=1e9,
                       max_steps=10**9)
    drift = np.full(times.size, np.nan)
    steps = 0
    status = L.ST_END_TIME
    hyb = state.copy()
    for i, t in enumerate(times):
        res = run_controller(FREE, hyb, robot=robot, t_end=float(t), integrator=integ,
                             log_capacity=0)
        steps += int(res.counts[L.K_STEPS])
        status = int(res.status)
        if status != L.ST_END_TIME:
            break
        hyb = res.state
        k, v = energy_parts(par, hyb)
        drift[i] = abs(k + v - e0) / (abs(k) + abs(v))
    return {"phase": phase, "rtol": float(rtol), "period": period, "time": times,
            "drift": drift, "growth_exponent": growth_exponent(times, drift),
            "drift_per_period": float(drift[-1] / periods), "steps": steps,
            "status": status, "energy0": float(e0)}


# --- long runs ---------------------------------------------------------------------------------
#: the long runs, in their dataset order: (name, controller kind, ticked)
LONG_RUNS = (("open_loop_tick", "open_loop", True), ("open_loop_exact", "open_loop", False),
             ("search_exact", "search", False), ("search_tick", "search", True))


def long_run_controller(kind: str, *, start, torque: float, tick: float, robot: Robot,
                        integrator: Integrator):
    """The controller of a long run and the gait it replays.

    ``open_loop``: the horizontal gait evaluated at ``start`` [rad s-1] with the controller
    ``tick`` [s] (0 = exact events), replayed by :class:`OpenLoop` from its ``t_switch`` and
    ``t_motor`` with the same tick (clock reset at each vertical crossing). ``search``: the
    state-based :class:`HorizontalSearch` looped. Returns ``(controller, t_switch, t_motor,
    gait status)``; the controller is None when the gait to replay fails (times NaN for
    ``search``).
    """
    if kind == "search":
        return HorizontalSearch(torque, tick=tick, loop=True), math.nan, math.nan, L.ST_OK
    if kind != "open_loop":
        raise ValueError(f"kind must be 'open_loop' or 'search', got {kind!r}")
    g = evaluate_gaits(np.array([start], float), robot=robot, torque=torque, tick=tick,
                       integrator=integrator)
    ts, tm, st = float(g["t_switch"][0]), float(g["t_motor"][0]), int(g["status"][0])
    if st != L.ST_OK:
        return None, ts, tm, st
    return OpenLoop(ts, tm, torque, tick=tick), ts, tm, st


def long_run(kind: str, *, start, cycles: int, torque: float, tick: float, robot: Robot,
             integrator: Integrator, max_drop: float) -> dict[str, Any]:
    """One long run from the gait start ``start`` (hanging from A, rates [rad s-1]): the
    controller of :func:`long_run_controller` for ``cycles`` cycles, stopped as ``fell``
    when the attached end sinks ``max_drop`` [m], bounded by ``integrator.max_steps``.

    Returns ``status``, ``cycles_completed``, ``steps``, ``nfev``, ``rejected``,
    ``t_final`` [s] (simulated time), ``final_pivot_height`` [m] (world height of the
    attached end at the end), ``finite`` (the final state is finite), ``t_switch``,
    ``t_motor`` [s]. When the gait to replay open loop fails at ``start``, the run does not
    start: its status is the gait's, with 0 cycles.
    """
    ctrl, ts, tm, gait_status = long_run_controller(kind, start=start, torque=torque,
                                                    tick=tick, robot=robot,
                                                    integrator=integrator)
    if ctrl is None:    # no gait to replay: the run ends before it starts, with its status
        return {"status": gait_status, "cycles_completed": 0, "steps": 0, "nfev": 0,
                "rejected": 0, "t_final": 0.0, "final_pivot_height": 0.0, "finite": 1,
                "t_switch": ts, "t_motor": tm}
    res = run_controller(ctrl, initial_state(float(start[0]), float(start[1])), robot=robot,
                         integrator=integrator, cycles=int(cycles), max_drop=max_drop,
                         log_capacity=4 * int(cycles) + 64)
    return {"status": int(res.status), "cycles_completed": int(res.counts[L.K_CYCLES]),
            "steps": int(res.counts[L.K_STEPS]), "nfev": int(res.counts[L.K_NFEV]),
            "rejected": int(res.counts[L.K_REJECTED]), "t_final": float(res.state[L.H_T]),
            "final_pivot_height": float(res.state[L.Y]),
            "finite": int(bool(np.all(np.isfinite(res.state[:8])))),
            "t_switch": ts, "t_motor": tm}


# --- extreme parameters ------------------------------------------------------------------------
def extreme_robot(case: str, robot: Robot) -> Robot:
    """The robot of an extreme case (``robot``: the study's, for the cases built on it)."""
    if case == "mass_ratio_1_100":
        return Robot(Link(1.0, 0.61, 0.3, 0.03), Link(100.0, 0.61, 0.3, 3.0),
                     gravity=robot.gravity, name=case)
    if case == "mass_ratio_100_1":
        return Robot(Link(100.0, 0.61, 0.3, 3.0), Link(1.0, 0.61, 0.3, 0.03),
                     gravity=robot.gravity, name=case)
    if case == "tiny_inertia":
        return Robot(Link(1.0, 0.61, 0.3, 1e-8), Link(1.0, 0.61, 0.3, 1e-8),
                     gravity=robot.gravity, name=case)
    if case == "cg_at_the_ends":
        return Robot(Link(1.0, 0.61, 0.0, 0.01), Link(1.0, 0.61, 0.61, 0.01),
                     gravity=robot.gravity, name=case)
    if case == "huge_velocities":
        return robot
    if case == "coulomb_sticking":
        return replace(robot, pivot_friction=COULOMB_FRICTION[0],
                       joint_friction=COULOMB_FRICTION[1])
    raise ValueError(f"case must be one of {list(EXTREME_CASES)}, got {case!r}")


def extreme_case(case: str, *, robot: Robot, torque: float, tick: float,
                 integrator: Integrator, points) -> dict[str, Any]:
    """Run one extreme case (:data:`EXTREME_CASES`).

    Parameter cases evaluate the horizontal gait (:func:`evaluate_gaits`, controller tick
    ``tick`` [s]) at ``points`` [rad s-1]; ``huge_velocities`` at :data:`HUGE_VELOCITIES`;
    ``coulomb_sticking`` runs :data:`FREE` for :data:`COULOMB_T_END` s from
    :data:`COULOMB_START` (its status is ``end_time`` when it reaches the end).

    Returns ``status`` (int8 per run), ``finite_ok`` (1 when every run marked ok - or, for
    the free run, ``end_time`` - has a finite result and final state and every other run's
    error is NaN), ``max_steps`` (most accepted steps of one run), ``energy_change`` [J]
    (free run: final minus initial total energy; NaN for gait cases), ``friction_events``.
    """
    rb = extreme_robot(case, robot)
    if case == "coulomb_sticking":
        start = initial_state(*COULOMB_START)
        res = run_controller(FREE, start, robot=rb, t_end=COULOMB_T_END,
                             integrator=replace(integrator, max_time=1e9))
        par = res.params
        e0, e1 = sum(energy_parts(par, start)), sum(energy_parts(par, res.state))
        finite = bool(np.all(np.isfinite(res.state[:8])) and math.isfinite(e1))
        fric = int(np.count_nonzero(res.log[:, L.L_KIND] == L.LOG_FRICTION))
        return {"status": np.array([int(res.status)], np.int8),
                "finite_ok": int(finite or res.status != L.ST_END_TIME),
                "max_steps": int(res.counts[L.K_STEPS]), "energy_change": float(e1 - e0),
                "friction_events": fric}
    pts = np.asarray(HUGE_VELOCITIES if case == "huge_velocities" else points,
                     float).reshape(-1, 2)
    r = evaluate_gaits(pts, robot=rb, torque=torque, tick=tick, integrator=integrator)
    ok = r["status"] == L.ST_OK
    finite = (np.all(np.isfinite(r["error"][ok]))
              and np.all(np.isfinite(r["final_state"][ok]))
              and np.all(np.isfinite(r["t_end"][ok]))
              and np.all(np.isnan(r["error"][~ok])))
    return {"status": r["status"].astype(np.int8), "finite_ok": int(bool(finite)),
            "max_steps": int(r["steps"].max()) if r["steps"].size else 0,
            "energy_change": math.nan, "friction_events": 0}


__all__ = ["COULOMB_FRICTION", "DRIFT_FLOOR", "DRIFT_PHASES", "EXTREME_CASES", "FLIGHT_START",
           "HUGE_VELOCITIES", "LONG_RUNS", "SWING_START", "checkpoint_times", "drift_start",
           "energy_drift", "energy_parts", "extreme_case", "extreme_robot", "frictionless",
           "growth_exponent", "long_run", "long_run_controller", "reference_period"]
