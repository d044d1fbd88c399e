"""Survival under noise: how many cycles a gait lasts on a noisy robot, and the mean
first-passage time (MFPT) to failure.

A Floquet multiplier says whether a gait returns to itself; a real robot swaps magnets a few
milliseconds early or late, senses angles with noise and never has its nominal masses.
Legged-robot research measures how long a gait lasts under such noise as *metastability*
(Byl & Tedrake, "Metastable walking machines", IJRR 28(8), 2009): the expected number of
steps before a fall. Here:

* :class:`Noise` - the noise sources, each optional, in SI units; :data:`SOURCES` declares
  each (where a study states it, its units, what it is);
* :func:`noise_roles` - which row of a controller program each source acts on;
* :func:`survival_runs` - independent runs of up to ``max_cycles`` cycles (compiled, one
  call per block of runs; :mod:`monkeystudy.kernel.survival`), each run's noise keyed by
  ``(seed, run, cycle)`` so any worker count gives the same numbers;
* :func:`survival_curve`, :func:`mfpt` - the survival fraction per cycle and the MFPT with a
  95 % confidence interval from the runs' cycles to failure, right-censored runs included.

The MFPT estimator
------------------
Let ``T`` be the cycles a run completes before it fails (a run that fails in its first cycle
has ``T = 0``) and ``M = max_cycles``; a run that completes ``M`` cycles is right-censored.
The survival fraction ``S(c) = P(T >= c)`` is the fraction of runs with ``T >= c`` for
``c <= M`` (every run is censored at the same ``M``, so this is the Kaplan-Meier estimate).
``MFPT = E[T] = sum_{c >= 1} S(c)``:

* up to ``M`` the sum is the restricted mean ``sum_{c=1..M} S(c) = mean(min(T, M))``;
* beyond ``M`` the failure rate is taken as constant (a metastable gait's first-passage time
  is exponential once its transient is over, Byl & Tedrake): the per-cycle hazard ``h`` is
  estimated over the window's second half, ``h = failures / cycles at risk`` there, and the
  tail adds ``S(M) (1 - h) / h``. With no censored run the tail is zero and the estimate is
  the sample mean, whatever the distribution.

The interval is a percentile bootstrap over runs (2000 resamples, a fixed generator), which
carries the censoring and the tail fit along. When no run fails in the window's second half
while some are censored, the tail cannot be fitted: ``mfpt`` is NaN, ``mfpt_low`` is the
restricted mean plus the tail at the hazard's 97.5 % Poisson upper bound, and ``mfpt_high``
is infinite. The hazards in the window's two halves are reported, so a user can see whether
the constant-rate tail is plausible.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace
from typing import Callable, Sequence

import numpy as np

from ..controllers import Integrator, Observer, kernel_method, settings_vector
from ..kernel import layout as L
from ..kernel.noise import PER_RUN_CYCLE, standard_draw
from ..kernel.survival import survival_runs as run_block
from ..robot import Friction, Link, Robot
from ..simulation import RobotLike, as_robot, run_controller

#: noise distributions: name -> the kernel's NZ_UNIFORM flag
DISTRIBUTIONS = {"gaussian": 0.0, "uniform": 1.0}

#: a survival run's failure (:attr:`SurvivalRuns.failure`) when a cycle ended farther than the
#: error bound from the gait; the other failures are the failing cycle's
#: :class:`~monkeystudy.simulation.Status`
ERROR_BOUND = L.ST_ERROR_BOUND
#: a survival run's failure when a cycle advanced less than the minimum advance
STALLED = L.ST_STALLED

#: per-run draws (cycle word PER_RUN_CYCLE): slots 0-2 are the initial state's (kernel);
#: the robot's uncertain parameters take these
PARAMETER_SLOTS = {("link1", "mass"): 16, ("link2", "mass"): 17, ("link1", "com"): 18,
                   ("link2", "com"): 19, ("link1", "inertia"): 20, ("link2", "inertia"): 21}
#: per-run draws of the friction (slots 22 and 23 are the kernel's latency and bar spacing):
#: (joint, kind) -> slot
FRICTION_SLOTS = {("pivot", "viscous"): 24, ("pivot", "coulomb"): 25,
                  ("joint", "viscous"): 26, ("joint", "coulomb"): 27}


@dataclass(frozen=True)
class NoiseSource:
    """One noise source: a field of :class:`Noise`, and what the layers above derive from it
    (the study file's ``noise:``, the survival dataset's ``noise_<name>`` variable, the units
    of the figures' axes; a figure's text is the figure's own).

    ``key`` is where a study file states it (below ``noise:``); ``units`` its SI units;
    ``what`` what it is (the dataset variable's ``long_name``); ``described`` what a study file
    sets with it (the schema's description, units in brackets); ``bound`` its largest value in a study file (None: no bound);
    ``uniform_per_run`` a value drawn once per run uniformly on ``[0, value)``, whatever the
    distribution; ``in_kernel`` whether the kernel draws it (its noise vector's slot
    ``NZ_<NAME>``) rather than :func:`run_robot`; ``when_set`` a source added after datasets
    without it were written: its dataset variable and its entry in :meth:`Noise.to_dict`
    appear only when it is non-zero, so the datasets of runs without it stay as they were.
    """

    name: str
    key: tuple[str, ...]
    units: str
    what: str
    described: str
    bound: float | None = None
    uniform_per_run: bool = False
    in_kernel: bool = True
    when_set: bool = False


def _source(key: tuple[str, ...], units: str, what: str, described: str, **kw) -> float:
    """A :class:`Noise` field (0: off) that declares its :class:`NoiseSource`."""
    return field(default=0.0, metadata={"source": dict(key=key, units=units, what=what,
                                                       described=described, **kw)})


@dataclass(frozen=True)
class Noise:
    """Noise sources of a survival run, each 0 (off) by default: every field but
    ``distribution`` is a source, declared with what it is (:data:`SOURCES`, in this order).

    ``distribution`` gives each draw's shape: ``gaussian`` (the value is the standard
    deviation) or ``uniform`` (the value is the half-width).

    Parameters
    ----------
    timing : float
        Actuation timing jitter [s], per magnet or motor action: a scheduled action (a time
        guard) happens that much early or late; an action triggered by a sensed state waits
        the draw's magnitude (a latency).
    angle, rate, height, energy : float
        Sensor noise on what state guards read: an angle [rad], an angular rate [rad s-1],
        a height [m], an energy [J]; one draw per guarded action.
    torque : float
        Relative error of each motor pulse's torque [1].
    mass, com, inertia : float
        Relative uncertainty of each link's mass, CG position and inertia [1], drawn once
        per run (the CG is kept on the link).
    theta2, dtheta1, dtheta2 : float
        Perturbation of the starting section state [rad, rad s-1, rad s-1], once per run.
    latency : float
        Actuation latency [s]: each run draws one value uniformly on ``[0, latency)`` (always
        uniform: a build's actuator delay) that delays every magnet and motor action of the
        run, on top of the jitter.
    pivot_viscous, pivot_coulomb, joint_viscous, joint_coulomb : float
        Absolute uncertainty of the friction at the pivot (the holding hook or magnet) and at
        the joint, viscous [N m s] and Coulomb [N m], drawn once per run about the robot's
        own value (a draw below zero is zero: friction does not drive).
    bar_spacing : float
        The ladder's spacing error [m], drawn once per run: every bar of the run lies that
        much farther from the bar before it than the gait's bars (a narrower ladder for a
        negative draw). A gait without bar catches is not affected.
    """

    distribution: str = "gaussian"
    timing: float = _source(
        ("timing",), "s", "actuation timing jitter",
        "actuation timing jitter per magnet or motor action [s]: a scheduled action moves "
        "early or late, an action triggered by a sensed state waits the draw's magnitude",
        bound=1.0)
    angle: float = _source(
        ("sensor", "angle"), "rad", "sensor noise on angle guards",
        "angles (coordinate guards on theta1, theta2) [rad]")
    rate: float = _source(
        ("sensor", "rate"), "rad s-1", "sensor noise on rate guards",
        "angular rates (guards on dtheta1, dtheta2) [rad s-1]")
    height: float = _source(
        ("sensor", "height"), "m", "sensor noise on height guards",
        "heights (free-end height guards, x or y guards) [m]")
    energy: float = _source(
        ("sensor", "energy"), "J", "sensor noise on energy guards",
        "energies (energy and energy-restored guards) [J]")
    torque: float = _source(
        ("torque",), "1", "relative torque error of each motor pulse",
        "relative torque error of each motor pulse [1]", bound=1.0)
    mass: float = _source(
        ("parameters", "mass"), "1", "relative uncertainty of each link's mass",
        "relative uncertainty of each link's mass [1]", bound=0.5, in_kernel=False)
    com: float = _source(
        ("parameters", "com"), "1", "relative uncertainty of each link's CG position",
        "relative uncertainty of each link's CG position [1] (the CG is kept on the link)",
        bound=0.5, in_kernel=False)
    inertia: float = _source(
        ("parameters", "inertia"), "1", "relative uncertainty of each link's inertia",
        "relative uncertainty of each link's inertia [1]", bound=0.5, in_kernel=False)
    theta2: float = _source(
        ("initial_state", "theta2"), "rad", "perturbation of the start's theta2",
        "theta2 [rad]")
    dtheta1: float = _source(
        ("initial_state", "dtheta1"), "rad s-1", "perturbation of the start's dtheta1",
        "dtheta1 [rad s-1]")
    dtheta2: float = _source(
        ("initial_state", "dtheta2"), "rad s-1", "perturbation of the start's dtheta2",
        "dtheta2 [rad s-1]")
    latency: float = _source(
        ("latency",), "s", "actuation latency, drawn once per run uniformly on [0, value): "
        "the upper end of its range",
        "actuation latency [s]: each run draws one value uniformly on [0, latency) (uniform "
        "whatever the distribution: a build's actuator delay), added to the delay of every "
        "magnet and motor action of the run, before the jitter",
        bound=1.0, uniform_per_run=True)
    pivot_viscous: float = _source(
        ("friction", "pivot_viscous"), "N m s", "uncertainty of the pivot's viscous friction",
        "the pivot's viscous friction [N m s], absolute, about the robot's", bound=10.0,
        in_kernel=False, when_set=True)
    pivot_coulomb: float = _source(
        ("friction", "pivot_coulomb"), "N m", "uncertainty of the pivot's Coulomb friction",
        "the pivot's Coulomb friction [N m], absolute, about the robot's", bound=10.0,
        in_kernel=False, when_set=True)
    joint_viscous: float = _source(
        ("friction", "joint_viscous"), "N m s", "uncertainty of the joint's viscous friction",
        "the joint's viscous friction [N m s], absolute, about the robot's", bound=10.0,
        in_kernel=False, when_set=True)
    joint_coulomb: float = _source(
        ("friction", "joint_coulomb"), "N m", "uncertainty of the joint's Coulomb friction",
        "the joint's Coulomb friction [N m], absolute, about the robot's", bound=10.0,
        in_kernel=False, when_set=True)
    bar_spacing: float = _source(
        ("bar_spacing",), "m", "spacing error of the run's ladder, drawn once per run",
        "the ladder's spacing error [m]: one draw per run, added to the distance of every "
        "bar from the bar before it (a bar is the world's: no sensor, no jitter)", bound=0.1,
        when_set=True)

    def __post_init__(self):
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"distribution must be one of {sorted(DISTRIBUTIONS)}, "
                             f"got {self.distribution!r}")
        for s in SOURCES:
            v = float(getattr(self, s.name))
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"noise {s.name} must be finite and >= 0, got {v!r}")

    def vector(self) -> np.ndarray:
        """The kernel's noise vector (layout ``NZ_*``: the sources it draws by their names)."""
        v = np.zeros(L.N_NOISE)
        v[L.NZ_UNIFORM] = DISTRIBUTIONS[self.distribution]
        for s in SOURCES:
            if s.in_kernel:
                v[getattr(L, f"NZ_{s.name.upper()}")] = getattr(self, s.name)
        return v

    def to_dict(self) -> dict:
        """The noise as a mapping (``Noise(**d)`` gives it back); a source added later
        (``when_set``) is left out while it is zero."""
        out = asdict(self)
        for s in SOURCES:
            if s.when_set and out[s.name] == 0.0:
                del out[s.name]
        return out

    @property
    def per_run_robot(self) -> bool:
        """Whether each run draws its own robot (:func:`run_robot`)."""
        return any(getattr(self, s.name) > 0.0 for s in SOURCES if not s.in_kernel)


#: every noise source, in the order of :class:`Noise`'s fields: the one declaration the study
#: file's ``noise:``, the survival dataset's variables and the figures derive from
SOURCES: tuple[NoiseSource, ...] = tuple(NoiseSource(f.name, **f.metadata["source"])
                                         for f in fields(Noise) if "source" in f.metadata)


#: the sensor each guard reads: guard kind -> noise source (coordinate guards by index)
_GUARD_SOURCE = {L.G_FREE_END_HEIGHT: L.NZ_HEIGHT, L.G_FREE_END_Y: L.NZ_HEIGHT,
                 L.G_ENERGY_RESTORED: L.NZ_ENERGY, L.G_ENERGY: L.NZ_ENERGY}
_COORD_SOURCE = {L.X: L.NZ_HEIGHT, L.Y: L.NZ_HEIGHT, L.TH1: L.NZ_ANGLE, L.TH2: L.NZ_ANGLE,
                 L.DTH1: L.NZ_RATE, L.DTH2: L.NZ_RATE}


def noise_roles(prog: np.ndarray) -> np.ndarray:
    """The noise role of each program row (layout ``RL_*``).

    A row's exit is an *actuation* when the row it leads to switches a magnet or changes the
    motor torque: its timing jitters (a time guard's instant shifts either way, a state
    guard's action waits, ``JITTER_LATENCY``). A state guard reads a sensor: coordinates by
    their kind (angles, rates; positions as heights), heights and energies (``RL_SENSOR``).
    A row with a non-zero torque is a motor pulse (``RL_PULSE``). A catch on a bar
    (``G_BAR``) is physical: no sensor, no jitter, no latency.
    """
    prog = np.asarray(prog, float)
    roles = np.zeros((prog.shape[0], L.N_ROLE_COLS))
    for k, row in enumerate(prog):
        nxt = int(row[L.S_NEXT])
        if nxt >= 0:
            to = prog[nxt]
            actuation = (to[L.S_SWAP] > 0 or to[L.S_MAG_A] >= 0 or to[L.S_MAG_B] >= 0
                         or to[L.S_TORQUE] != row[L.S_TORQUE])
            # a catch on a bar is the hook meeting the bar: no controller acts, nothing jitters
            if actuation and int(row[L.S_GUARD]) != L.G_BAR:
                roles[k, L.RL_JITTER] = (L.JITTER_SHIFT if int(row[L.S_GUARD]) == L.G_TIME
                                         else L.JITTER_LATENCY)
        guard = int(row[L.S_GUARD])
        if guard == L.G_COORD:
            roles[k, L.RL_SENSOR] = _COORD_SOURCE.get(int(row[L.S_GINDEX]), 0)
        else:
            roles[k, L.RL_SENSOR] = _GUARD_SOURCE.get(guard, 0)
        roles[k, L.RL_PULSE] = 1.0 if row[L.S_TORQUE] != 0.0 else 0.0
    return roles


def run_robot(robot: Robot, noise: Noise, seed: int, run: int) -> Robot:
    """The robot of run ``run``: each link's mass, CG and inertia times ``1 + s z`` (``s``
    the noise's relative scale, ``z`` the run's draw), the CG clipped onto the link; each
    friction coefficient plus ``s z`` (``s`` the noise's absolute scale), clipped at zero.
    The rotor, the motor and what the noise leaves alone are the robot's."""
    if not noise.per_run_robot:
        return robot
    uniform = noise.distribution == "uniform"
    friction = {}
    for joint in ("pivot", "joint"):
        own = getattr(robot, f"{joint}_friction")
        vals = {}
        for kind in ("viscous", "coulomb"):
            scale = getattr(noise, f"{joint}_{kind}")
            z = standard_draw(int(seed), int(run), PER_RUN_CYCLE, FRICTION_SLOTS[(joint, kind)],
                              uniform) if scale > 0.0 else 0.0
            vals[kind] = max(getattr(own, kind) + scale * z, 0.0) if scale > 0.0 \
                else getattr(own, kind)
        friction[joint] = Friction(vals["viscous"], vals["coulomb"])
    links = {}
    for name in ("link1", "link2"):
        link = getattr(robot, name)
        if noise.mass == 0.0 and noise.com == 0.0 and noise.inertia == 0.0:
            links[name] = link
            continue
        vals = {}
        for what in ("mass", "com", "inertia"):
            scale = getattr(noise, what)
            z = standard_draw(int(seed), int(run), PER_RUN_CYCLE, PARAMETER_SLOTS[(name, what)],
                              uniform) if scale > 0.0 else 0.0
            vals[what] = getattr(link, what) * (1.0 + scale * z)
        vals["com"] = min(max(vals["com"], 0.0), link.length)
        # the CG's offset across the link is kept: the noise scales its distance along it
        links[name] = Link(vals["mass"], link.length, vals["com"], vals["inertia"],
                           link.com_across)
    return replace(robot, link1=links["link1"], link2=links["link2"],
                   pivot_friction=friction["pivot"], joint_friction=friction["joint"])


def catches_per_cycle(prog: np.ndarray) -> int:
    """Bar catches (rows guarded by ``G_BAR``) per cycle of a looping controller program: a
    bar gait's brachiations per cycle (0 for a gait that catches no bar).

    Raises
    ------
    ValueError
        The program has no cycle-ending row, or its catches do not divide among its cycles.
    """
    prog = np.asarray(prog, float)
    cycles = int(np.sum(prog[:, L.S_CYCLE] > 0))
    catches = int(np.sum(prog[:, L.S_GUARD] == L.G_BAR))
    if cycles == 0:
        raise ValueError("the controller's program has no cycle-ending row")
    if catches % cycles:
        raise ValueError(f"the program's {catches} bar catches do not divide among its "
                         f"{cycles} cycles")
    return catches // cycles


@dataclass
class SurvivalRuns:
    """Outcome of a block of runs (arrays over the runs).

    ``cycles`` completed within bounds; ``failure`` the failing cycle's status (``ok``: the
    run completed ``max_cycles`` and is censored; :data:`ERROR_BOUND`: the error bound;
    :data:`STALLED`: the minimum advance);
    ``distance`` the attached end's horizontal travel to the last completed cycle [m];
    ``time`` of that cycle's end [s]; ``error`` there [rad2 + rad2 s-2]; ``nfev`` the
    right-hand-side evaluations; ``height`` the attached end's height there less its planned
    height there [m]: its height at the start, plus the program's rise per completed cycle
    (:class:`~monkeystudy.controllers.PhaseSequence`).
    """

    cycles: np.ndarray
    failure: np.ndarray
    distance: np.ndarray
    time: np.ndarray
    error: np.ndarray
    nfev: np.ndarray
    height: np.ndarray


def travel_direction(controller, start: np.ndarray, *, robot: RobotLike = "seed2009",
                     integrator: Integrator = Integrator()) -> float:
    """The way a gait travels along the wall: the sign (+1.0 or -1.0) of its attached end's
    x change over one noiseless cycle of ``controller`` from the hybrid state ``start``
    (+1.0 when it does not move or the cycle fails). A survival run's minimum advance is
    measured this way (a ladder gait may go towards -x)."""
    r = run_controller(controller, np.asarray(start, dtype=np.float64), robot=robot,
                       integrator=integrator, cycles=1, log_capacity=64)
    moved = float(r.state[L.X]) - float(start[L.X])
    return -1.0 if int(r.status) == L.ST_OK and moved < 0.0 else 1.0


def survival_runs(controller, start: np.ndarray, reference, *, runs, max_cycles: int,
                  noise: Noise, seed: int, robot: RobotLike = "seed2009",
                  integrator: Integrator = Integrator(), error_bound: float = math.inf,
                  min_advance: float = -math.inf, travel: float = 1.0,
                  max_drop: float = math.inf,
                  section: Observer | Sequence[Observer] | None = None,
                  progress: Callable[[int], None] | None = None) -> SurvivalRuns:
    """Run ``controller`` (a looping program: each cycle ends on a ``cycle_end`` row) from the
    hybrid state ``start`` for each run number in ``runs``.

    Parameters
    ----------
    reference : array_like
        The gait's section state ``(theta2 [rad], dtheta1, dtheta2 [rad s-1])`` the error of
        each cycle is measured against (and ``start``'s noiseless section state).
    max_cycles : int
        Cycles after which a run stops as censored.
    noise : Noise
        The noise sources; ``seed`` keys every draw with the run number and the cycle.
    error_bound : float
        A cycle ending with a larger error fails the run [rad2 + rad2 s-2].
    min_advance : float
        A cycle whose attached end advances horizontally less than this fails the run
        (stalled) [m].
    travel : float
        The direction the advance is measured in: +1 (default) world +x, -1 world -x (a gait
        that travels that way).
    max_drop : float
        A run fails when the attached end sinks this far below its planned height (its
        start's, plus the program's rise per completed cycle) [m].
    section : Observer or sequence of Observer, optional
        An exact observer of the section, watched in the cycle's last row, where each cycle
        is measured (one per cycle-ending row of a program that loops over several; default:
        the controller's own observers, else the cycle's end).
    progress : callable, optional
        Called with 1 as each run ends (the runs are then run one by one: each run's
        numbers are the same either way, as its noise depends on the seed, the run number
        and the cycle only).
    """
    robot = as_robot(robot)
    prog, obs = controller.program()
    if section is not None:
        sections = (section,) if isinstance(section, Observer) else tuple(section)
        obs = np.vstack([obs, *(o.row()[None, :] for o in sections)])
    if not np.any(prog[:, L.S_CYCLE] > 0):
        raise ValueError("the controller's program has no cycle-ending row")
    if int(max_cycles) < 1:
        raise ValueError(f"max_cycles must be >= 1, got {max_cycles}")
    if travel not in (1.0, -1.0):
        raise ValueError(f"travel must be +1 or -1, got {travel!r}")
    runs = np.asarray(runs, dtype=np.int64).ravel()
    settings = settings_vector(integrator, tick=controller.tick,
                               tick_phase=controller.tick_phase, max_drop=max_drop)
    par_runs = np.stack([run_robot(robot, noise, seed, r).params() for r in runs]) \
        if len(runs) else np.empty((0, 2, L.N_PARAMS))
    out = np.zeros((len(runs), L.N_SV_COLS))
    start = np.asarray(start, float)
    method, roles, vector = kernel_method(settings, prog, start[L.H_PHASE]), \
        noise_roles(prog), noise.vector()
    reference = np.asarray(reference, float)
    pieces = [slice(0, len(runs))] if progress is None else \
        [slice(i, i + 1) for i in range(len(runs))]
    for part in pieces:
        run_block(method, par_runs[part], prog, obs, settings, start, roles, vector,
                  int(seed), runs[part], reference, int(max_cycles), float(error_bound),
                  float(min_advance), float(travel), out[part])
        if progress is not None:
            progress(part.stop - part.start)
    return SurvivalRuns(out[:, L.SV_CYCLES].astype(np.int64),
                        out[:, L.SV_FAILURE].astype(np.int8), out[:, L.SV_DISTANCE].copy(),
                        out[:, L.SV_TIME].copy(), out[:, L.SV_ERROR].copy(),
                        out[:, L.SV_NFEV].astype(np.int64), out[:, L.SV_HEIGHT].copy())


# ------------------------------------------------------------------------------------------
# estimators
# ------------------------------------------------------------------------------------------
#: bootstrap resamples of the MFPT interval, and its generator's fixed seed
BOOTSTRAP_SAMPLES = 2000
BOOTSTRAP_SEED = 20090917
#: the two-sided 97.5 % Poisson upper bound on a mean with no event observed (-ln 0.025)
POISSON_UPPER_ZERO = -math.log(0.025)


def survival_curve(cycles, max_cycles: int, at) -> np.ndarray:
    """``S(c)``: the fraction of runs that completed at least ``c`` cycles, for each ``c`` in
    ``at`` (``c <= max_cycles``; every run is censored at ``max_cycles``)."""
    t = np.sort(np.asarray(cycles, np.int64))
    at = np.asarray(at, np.int64)
    if np.any(at > max_cycles):
        raise ValueError("the survival fraction is known up to max_cycles only")
    if t.size == 0:
        return np.full(at.shape, np.nan)
    return (t.size - np.searchsorted(t, at, side="left")) / t.size


def hazard(cycles, failed, first: int, last: int) -> tuple[int, int]:
    """Failures and cycles at risk over cycles ``first + 1 .. last`` (1-based): a run that
    completed ``T`` cycles was at risk in cycles ``1 .. T + 1`` if it failed (the last one
    failing), ``1 .. T`` if censored."""
    t = np.asarray(cycles, np.int64)
    f = np.asarray(failed, bool)
    attempted = np.where(f, t + 1, t)
    at_risk = np.clip(attempted, first, last) - first
    failures = int(np.sum(f & (t + 1 > first) & (t + 1 <= last)))
    return failures, int(at_risk.sum())


@dataclass(frozen=True)
class MFPT:
    """Mean first-passage time in cycles with its 95 % interval; see the module docstring.

    ``method``: ``mean`` (no censored run), ``tail`` (restricted mean plus a constant-hazard
    tail), ``lower_bound`` (no failure to fit the tail on: ``value`` NaN) or ``none`` (no
    run). ``hazard_early``, ``hazard_late``: failures per cycle at risk in the window's first
    and second halves (NaN when no cycle was at risk).
    """

    value: float
    low: float
    high: float
    method: str
    restricted_mean: float
    censored: int
    failures: int
    hazard_early: float
    hazard_late: float


def _mfpt_points(t: np.ndarray, failed: np.ndarray, max_cycles: int,
                 samples: np.ndarray) -> np.ndarray:
    """The MFPT point estimate [cycles] of each resample of the runs (rows of run indices
    ``samples``; inf where the tail cannot be fitted)."""
    half = max_cycles // 2
    attempted = np.where(failed, t + 1, t)
    restricted = np.minimum(t, max_cycles).astype(float)
    censored = (~failed).astype(float)
    tail_failures = (failed & (t + 1 > half) & (t + 1 <= max_cycles)).astype(float)
    tail_exposure = (np.clip(attempted, half, max_cycles) - half).astype(float)
    rmst = restricted[samples].mean(axis=1)
    s_end = censored[samples].mean(axis=1)
    d = tail_failures[samples].sum(axis=1)
    e = tail_exposure[samples].sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        tail = np.where(d > 0, s_end * (e - d) / d, np.inf)   # S(M) (1 - h) / h, h = d / e
    return np.where(s_end > 0, rmst + tail, rmst)


def mfpt(cycles, failed, max_cycles: int) -> MFPT:
    """MFPT [cycles] of runs that completed ``cycles`` each (``failed``: False for a run
    censored at ``max_cycles``), with a 95 % percentile-bootstrap interval."""
    t = np.asarray(cycles, np.int64)
    f = np.asarray(failed, bool)
    n = t.size
    half = max_cycles // 2
    d1, e1 = hazard(t, f, 0, half)
    d2, e2 = hazard(t, f, half, max_cycles)
    rates = (d1 / e1 if e1 else math.nan, d2 / e2 if e2 else math.nan)
    if n == 0:
        return MFPT(math.nan, math.nan, math.nan, "none", math.nan, 0, 0, *rates)
    rmst = float(np.mean(np.minimum(t, max_cycles)))
    censored = int(np.sum(~f))
    point = float(_mfpt_points(t, f, max_cycles, np.arange(n)[None, :])[0])
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    boot = np.empty(BOOTSTRAP_SAMPLES)
    rows = max(1, (1 << 22) // n)         # resamples per batch: bounded memory
    for lo in range(0, BOOTSTRAP_SAMPLES, rows):
        hi = min(lo + rows, BOOTSTRAP_SAMPLES)
        boot[lo:hi] = _mfpt_points(t, f, max_cycles, rng.integers(0, n, size=(hi - lo, n)))
    low, high = (float(v) for v in np.quantile(boot, [0.025, 0.975], method="lower"))
    if censored == 0:
        method = "mean"
    elif math.isfinite(point):
        method = "tail"
    else:
        method = "lower_bound"
        s_end = float(np.mean(t >= max_cycles))
        h_up = POISSON_UPPER_ZERO / e2
        point = math.nan
        low = rmst + s_end * (1.0 - h_up) / h_up
        high = math.inf
    return MFPT(point, low, high, method, rmst, censored, int(np.sum(f)), *rates)


def cycle_grid(max_cycles: int, points: int = 160) -> np.ndarray:
    """Cycles at which a survival curve is stored: 0, 1, 2, ... then logarithmically spaced
    up to ``max_cycles`` (``S`` is a step function; its values at these cycles are exact)."""
    g = np.unique(np.round(np.logspace(0.0, math.log10(max(max_cycles, 1)), points)))
    return np.unique(np.concatenate([[0], g.astype(np.int64), [max_cycles]]))


__all__ = ["DISTRIBUTIONS", "MFPT", "Noise", "NoiseSource", "SOURCES", "SurvivalRuns",
           "catches_per_cycle", "cycle_grid", "hazard", "mfpt", "noise_roles", "run_robot",
           "survival_curve", "survival_runs"]
