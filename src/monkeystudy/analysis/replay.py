"""Many cycles of a gait: its own controller or an open-loop replay, and basins.

A gait (:class:`~monkeystudy.controllers.SequenceGait`; the study's horizontal gait is
:func:`~monkeystudy.controllers.horizontal_gait`) can be run two ways from a start on its
section:

- ``replay="gait"``: the controller as written, state guards and all (the map whose Floquet
  multipliers the floquet step computes);
- ``replay="open_loop"``: every segment before the section ends at the time it ended on the
  recorded cycle, counted on the controller clock, which restarts at each section crossing
  (the study's ``reset_at_vertical``) or runs on with the gait's period (:func:`open_loop_gait`).
  Entry actions (magnets, motor, energy latch) are kept; only the guards become clocks. This
  is how the 2009 study replayed its gaits (swap at ``t_switch``, motor for ``t_motor``) and
  watched them drift.

Either way a controller tick (``tick`` [s]) delays each ticked guard to the next tick, so the
same functions answer "was it the 1 ms grid?" for any gait. Per cycle everything is measured
where the cycle reaches its section, in the frame of the end attached there
(:func:`sequence_cycles`): the gait's error against the start, the kinetic energy, the
attached end's world position; :func:`sequence_basin` counts the cycles a replay survives
from perturbed starts. Everything runs through :func:`monkeystudy.simulation.run_controller`:
nothing here integrates on its own.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..controllers import (
    ZERO_BAND, Integrator, Observer, PhaseSequence, SequenceGait, motorless, open_loop_gait,
)
from ..kernel import layout as L
from ..simulation import (
    RobotLike, RunResult, Status, as_robot, energies, evaluate_cycle_gaits, gait_error,
    run_controller,
)
from .sections import TIGHT, check_cycle_frame, cycle_section_state


# --- per-cycle errors -------------------------------------------------------------------------
#: the window of sqrt(error) [1] in which the growth per cycle is fitted (linear regime, above
#: round-off)
GROWTH_WINDOW = (1e-10, 1e-4)


def growth_per_cycle(error: np.ndarray, window=GROWTH_WINDOW) -> float:
    """``exp`` of the slope of ``log(sqrt(error))`` against the cycle number, fitted over the
    cycles with ``window[0] < sqrt(error) < window[1]``; NaN if fewer than 3 such cycles."""
    e = np.sqrt(np.asarray(error, float))
    with np.errstate(invalid="ignore"):
        lin = np.isfinite(e) & (e > window[0]) & (e < window[1])
    if int(lin.sum()) < 3:
        return math.nan
    c = np.flatnonzero(lin) + 1.0
    return float(np.exp(np.polyfit(c, np.log(e[lin]), 1)[0]))


def cycles_to_bound(error: np.ndarray, bound: float) -> int:
    """First cycle (1-based) whose error exceeds ``bound``; else the number of cycles run."""
    e = np.asarray(error, float)
    bad = np.flatnonzero(~(e <= bound))
    return int(bad[0]) + 1 if bad.size else int(e.size)


def sweep_ticks(ticks, cycles: int, error_bound: float, run_one) -> dict[str, np.ndarray]:
    """The controller-tick question: one run per tick [s], ``run_one(tick) -> (error per
    cycle, pivot height per cycle, status)``; per tick the errors and heights (NaN padded to
    ``cycles``), :func:`cycles_to_bound`, the cycles completed, the status and
    :func:`growth_per_cycle`."""
    n = len(ticks)
    out = {"error": np.full((n, cycles), np.nan), "pivot_height": np.full((n, cycles), np.nan),
           "cycles_to_bound": np.zeros(n, np.int32), "cycles_completed": np.zeros(n, np.int32),
           "status": np.zeros(n, np.int8), "growth_per_cycle": np.full(n, np.nan)}
    for i, tick in enumerate(ticks):
        error, pivot, status = run_one(tick)
        e = np.asarray(error, float)[:cycles]
        p = np.asarray(pivot, float)[:cycles]
        out["error"][i, :e.size] = e
        out["pivot_height"][i, :p.size] = p
        out["cycles_to_bound"][i] = cycles_to_bound(e, error_bound)
        out["cycles_completed"][i] = e.size
        out["status"][i] = int(status)
        out["growth_per_cycle"][i] = growth_per_cycle(e)
    return out


# --- sequence gaits ---------------------------------------------------------------------------
#: the two ways of running a sequence gait for many cycles
REPLAYS = ("gait", "open_loop")


def section_error(states: np.ndarray, z) -> np.ndarray:
    """Section error of frame states ``[..., 8]`` against ``z = (theta2 [rad], dtheta1,
    dtheta2 [rad s-1])``: ``wrap(theta2_f - theta2)^2 + (dtheta1_f - dtheta1)^2 + (dtheta2_f -
    dtheta2)^2`` (docs/model.md section 4 generalised; :class:`SequenceGait`) [rad2 + rad2
    s-2]. A running clock's ``z = (theta1, theta2, dtheta1, dtheta2)`` adds ``(theta1_f -
    theta1)^2``."""
    s = np.asarray(states, float)
    z = [float(v) for v in z]
    extra = 0.0
    if len(z) == 4:
        extra = (s[..., L.TH1] - z[0]) ** 2
        z = z[1:]
    th2, w1, w2 = z
    d = (s[..., L.TH2] - th2 + math.pi) % (2.0 * math.pi) - math.pi  # kernel's wrap
    return extra + d * d + (s[..., L.DTH1] - w1) ** 2 + (s[..., L.DTH2] - w2) ** 2


def cycle_times(gait: SequenceGait, z, *, robot: RobotLike = "seed2009",
                integrator: Integrator = TIGHT) -> np.ndarray:
    """Exit time [s] of each segment of one cycle from section state ``z`` (the section's
    last), on the controller clock from the cycle start (a running clock's ``z`` starts with
    ``theta1``, the section's). ``ValueError`` if the cycle does not close (its status is not
    ok)."""
    g = replace(gait, theta2=float(z[-3]))
    r = evaluate_cycle_gaits([[float(z[-2]), float(z[-1])]], g, robot=robot,
                             integrator=integrator)
    if int(r["status"][0]) != L.ST_OK:
        raise ValueError(f"the cycle from {tuple(float(v) for v in z)} does not close: "
                         f"{L.STATUS_NAMES[int(r['status'][0])]}")
    return r["t_segment"][0].copy()


def section_watch(gait: SequenceGait) -> tuple[Observer, ...]:
    """Exact observers of the section crossing (:meth:`~monkeystudy.controllers.
    SequenceGait.section_observer`) in the rows of :meth:`~monkeystudy.controllers.
    SequenceGait.loop_segments` where a cycle's crossing can fall: each section row; for a
    running clock recorded from the swap (``records='swap'``) also every row after it up to
    the next swap, since the clock's period ends where it ends, before or after link 1
    reaches the section (the crossing recorded is the first after the cycle's motor phase)."""
    rows = gait.loop_segments()
    watch = list(gait.cycle_end_rows())
    if gait.clocked and gait.records == "swap":
        magnets = set(gait.loop_magnet_rows())
        for row in gait.cycle_end_rows():
            k = row
            while k not in magnets:
                k = (k + 1) % len(rows)
                watch.append(k)
    return tuple(gait.section_observer(k) for k in sorted(set(watch)))


@dataclass
class SequenceCycles:
    """Per-cycle record of a multi-cycle run of a sequence gait (``run`` is the raw
    :class:`~monkeystudy.simulation.RunResult`).

    With the gait's ``records='section'``, one entry per cycle that reached its section. With
    ``records='swap'``, ``pivot_height``, ``x_advance`` and ``t_swap`` have one entry per
    swap (a last swap whose cycle failed included), the others one per swap up to the last
    one followed by a section crossing (NaN where a swap saw none before the next).
    """

    error: np.ndarray            # section error vs the reference [rad2 + rad2 s-2]
    kinetic_energy: np.ndarray   # [J] at each section crossing
    pivot_height: np.ndarray     # [m] world height of the attached end (see above)
    x_advance: np.ndarray        # [m] attached end's horizontal displacement in the cycle
    t_cross: np.ndarray          # [s] section crossing ending the cycle
    t_swap: np.ndarray           # [s] the cycle's first magnet action (NaN: none)
    section_state: np.ndarray    # (n, 8) frame state at each crossing (NaN: none)
    status: Status
    run: RunResult


def cycle_error(states: np.ndarray, z, gait: SequenceGait) -> np.ndarray:
    """The gait's error of frame states ``[n, 8]`` at its section against ``z``: the section
    error (:func:`section_error`) or, for a gait that does not wrap theta2, the 2009 error
    (:func:`~monkeystudy.simulation.gait_error`, ``theta2_f - theta2`` as it is) evaluated row
    by row, as the study's stability records always were (numpy's scalar ``** 2`` can differ
    from its array square in the last bit)."""
    s = np.asarray(states, float).reshape(-1, 8)
    if gait.wrap_theta2:
        return section_error(s, z)
    th2, w1, w2 = (float(v) for v in np.asarray(z, float)[-3:])
    rows = s.copy()
    rows[:, L.TH2] -= th2
    return np.array([gait_error(r, w1, w2) for r in rows], dtype=float)


def sequence_cycles(gait: SequenceGait, z0, *, cycles: int, robot: RobotLike = "seed2009",
                    integrator: Integrator = TIGHT, replay: str = "gait",
                    times=None, reference=None, tick: float | None = None,
                    tick_phase: float = 0.0, max_drop: float | None = None,
                    sample_dt: float = 0.0) -> SequenceCycles:
    """Run a sequence gait for ``cycles`` cycles from section state ``z0 = (theta2 [rad],
    dtheta1, dtheta2 [rad s-1])`` (running clock: ``(theta1, theta2, dtheta1, dtheta2)``),
    hanging from A at the origin.

    Parameters
    ----------
    replay : {"gait", "open_loop"}
        The gait's own controller, or its open-loop replay (:func:`open_loop_gait`) with the
        segment exit ``times`` [s] (default: :func:`cycle_times` at ``reference``; a gait
        found on another controller passes its recorded times).
    reference : array_like, optional
        The gait the error is measured against (default ``z0``), e.g. the fixed point when
        ``z0`` is a perturbed start.
    tick, tick_phase : float, optional
        Controller tick and its phase [s] (default: the gait's).
    max_drop : float, optional
        Stop with status ``fell`` when the attached end sinks this far [m] below its planned
        height: the start's, plus the gait's ``rise`` per completed cycle (default: link 1's
        length).
    sample_dt : float
        Record the trajectory every ``sample_dt`` [s] (0: none).

    Returns
    -------
    SequenceCycles
        Per cycle (ends at a fall, a missed guard or the horizon: ``status``), recorded as
        the gait's ``records`` says. Each cycle is measured where it reaches its section: at
        the section row's exit when the section is exact, else (a section acted on at the
        tick, or records from the swap) at an exact observer of the section crossing, which
        logs the same time and state as an exact section's exit. A cycle ending on B needs
        mirror-image links (``ValueError``).
    """
    if replay not in REPLAYS:
        raise ValueError(f"replay must be one of {REPLAYS}, got {replay!r}")
    if int(cycles) < 1:
        raise ValueError(f"cycles must be >= 1, got {cycles}")
    robot = as_robot(robot)
    check_cycle_frame(gait, robot)
    if gait.segments[0].magnets != "keep":
        # the log row of a section crossing holds the state after segment 0's entry action
        raise ValueError("a gait whose first segment acts on the magnets at the section "
                         "cannot be measured per cycle on its section")
    z0 = np.asarray(z0, float)
    ref = z0 if reference is None else np.asarray(reference, float)
    run_gait = gait
    if replay == "open_loop":
        if times is None:
            times = cycle_times(gait, ref, robot=robot, integrator=integrator)
        run_gait = open_loop_gait(gait, times)
    run_gait = replace(run_gait, theta2=float(z0[-3]),
                       tick=gait.tick if tick is None else float(tick),
                       tick_phase=gait.tick_phase if tick is None else float(tick_phase))
    if max_drop is None:
        max_drop = robot.link1.length
    rows = run_gait.loop_segments()
    observed = run_gait.section_ticked or run_gait.records == "swap"
    observers = section_watch(run_gait) if observed else ()
    ctrl = run_gait.loop_controller(observers)
    res = run_controller(ctrl, cycle_section_state(run_gait, z0), robot=robot,
                         integrator=integrator, cycles=int(cycles), max_drop=float(max_drop),
                         sample_dt=sample_dt,
                         log_capacity=(len(rows) + 2 + len(observers)) * int(cycles) + 16)
    log = res.log
    seg_rows = log[log[:, L.L_KIND] == L.LOG_SEGMENT]
    if observed:
        cross = log[log[:, L.L_KIND] == L.LOG_OBSERVER]
    else:
        cross = seg_rows[np.isin(seg_rows[:, L.L_ID].astype(int), run_gait.cycle_end_rows())]
    swaps = seg_rows[np.isin(seg_rows[:, L.L_ID].astype(int), run_gait.loop_magnet_rows())]
    if run_gait.records == "swap":
        status = Status(int(res.status))
        if run_gait.clocked and status == Status.OK:
            tail = _run_to_next_swap(run_gait, observers, res, robot=robot,
                                     integrator=integrator, max_drop=float(max_drop))
            cross = np.concatenate([cross, tail.log[tail.log[:, L.L_KIND] == L.LOG_OBSERVER]])
            status = Status(int(tail.status))
        edges = seg_rows[np.isin(seg_rows[:, L.L_ID].astype(int), run_gait.cycle_end_rows())]
        return _per_swap(run_gait, res, swaps, cross, ref, status,
                         _on_section(run_gait, edges) if run_gait.clocked else edges[:0])
    states = cross[:, L.L_STATE:L.L_STATE + 8].copy()
    ke, _ = energies(res.params, states, cross[:, L.L_FLIPPED])
    x_prev = np.concatenate([[0.0], states[:-1, L.X]])
    t_start = np.concatenate([[-math.inf], cross[:-1, L.L_T]])
    t_swap = np.full(len(cross), math.nan)
    for c in range(len(cross)):
        k = np.flatnonzero((swaps[:, L.L_T] > t_start[c]) & (swaps[:, L.L_T] <= cross[c, L.L_T]))
        if k.size:
            t_swap[c] = swaps[k[0], L.L_T]
    return SequenceCycles(cycle_error(states, ref, run_gait), ke, states[:, L.Y].copy(),
                          states[:, L.X] - x_prev, cross[:, L.L_T].copy(), t_swap, states,
                          Status(int(res.status)), res)


def _run_to_next_swap(gait: SequenceGait, observers, res: RunResult, *, robot, integrator,
                      max_drop: float) -> RunResult:
    """A running clock's run stops where its last period ends, which may come before its
    last cycle reaches the section: the run goes on from there (:attr:`RunResult.state`),
    ``observers`` watching, up to the next swap, where it stops (no samples)."""
    rows = gait.loop_segments()
    stop = set(gait.loop_magnet_rows())
    ctrl = PhaseSequence([replace(seg, next=-1) if k in stop else seg
                          for k, seg in enumerate(rows)], tuple(observers), gait.tick,
                         gait.tick_phase, gait.rise)
    state = res.state.copy()
    # the run stopped on its cycle-ending row, before the next row's entry actions
    prog, _ = ctrl.program()
    state[L.H_SEG] = prog[int(state[L.H_SEG]), L.S_NEXT]
    return run_controller(ctrl, state, robot=robot, integrator=integrator,
                          max_drop=max_drop, log_capacity=4 * len(rows) + 16)


def _on_section(gait: SequenceGait, exits: np.ndarray) -> np.ndarray:
    """The segment-exit log rows among ``exits`` whose link 1 is on the section to the
    kernel's zero band (:data:`~monkeystudy.controllers.ZERO_BAND`) and moving through it in
    the section's direction. The next row starts there with the observer's guard taken as
    zero, so a crossing within that band after the exit is not logged: it is the exit."""
    c = gait.section_theta1
    th1 = exits[:, L.L_STATE + L.TH1]
    w1 = exits[:, L.L_STATE + L.DTH1]
    way = {"rising": w1 > 0.0, "falling": w1 < 0.0, "either": w1 != 0.0}
    return exits[(np.abs(th1 - c) <= ZERO_BAND * (1.0 + abs(c)))
                 & way[gait.section_direction]]


def _per_swap(gait: SequenceGait, res: RunResult, swaps: np.ndarray, cross: np.ndarray,
              ref: np.ndarray, status: Status, edges: np.ndarray) -> SequenceCycles:
    """:class:`SequenceCycles` recorded from each swap: the attached end just after it, and
    the first section crossing after it and before the next swap (else a segment exit on
    the section, ``edges``, :func:`_on_section`); ``status`` the run's."""
    pivots = swaps[:, L.L_STATE:L.L_STATE + 8]
    x_prev = np.concatenate([[0.0], pivots[:-1, L.X]])   # the gait starts with A at x = 0
    t_next = np.append(swaps[1:, L.L_T], math.inf)
    picked = []
    for t0, t1 in zip(swaps[:, L.L_T], t_next):
        k = np.flatnonzero((cross[:, L.L_T] > t0) & (cross[:, L.L_T] < t1))
        if not k.size:        # none logged: an exit on the section, after the crossings
            k = len(cross) + np.flatnonzero((edges[:, L.L_T] > t0) & (edges[:, L.L_T] < t1))
        picked.append(int(k[0]) if k.size else -1)
    cross = np.concatenate([cross, edges])
    while picked and picked[-1] < 0:
        picked.pop()                      # swaps after the last crossing have no cycle end
    n = len(picked)
    states = np.full((n, 8), np.nan)
    t_cross = np.full(n, np.nan)
    ke = np.full(n, np.nan)
    err = np.full(n, np.nan)
    hit = np.array([k >= 0 for k in picked], bool)
    if hit.any():
        rows = cross[[k for k in picked if k >= 0]]
        states[hit] = rows[:, L.L_STATE:L.L_STATE + 8]
        t_cross[hit] = rows[:, L.L_T]
        ke[hit], _ = energies(res.params, states[hit], rows[:, L.L_FLIPPED])
        err[hit] = cycle_error(states[hit], ref, gait)
    return SequenceCycles(err, ke, pivots[:, L.Y].copy(), pivots[:, L.X] - x_prev, t_cross,
                          swaps[:, L.L_T].copy(), states, status, res)


def sequence_basin(gait: SequenceGait, z_star, offsets1, offsets2, *, max_cycles: int = 60,
                   error_bound: float = 1e-2, robot: RobotLike = "seed2009",
                   integrator: Integrator = TIGHT, replay: str = "gait", times=None,
                   tick: float | None = None, max_drop: float | None = None) -> np.ndarray:
    """Cycles a sequence gait survives from perturbed starts (a basin map).

    Start ``z_star`` with ``a`` added to dtheta1 for ``a`` in ``offsets1`` and ``b`` to
    dtheta2 for ``b`` in ``offsets2`` [rad s-1];
    a run fails at the first section crossing whose error against ``z_star`` exceeds
    ``error_bound``, or when it falls or stops before. The open-loop replay keeps the fixed
    point's segment exit ``times`` [s] for every start (default: :func:`cycle_times` at
    ``z_star``). Returns int ``[len(offsets1), len(offsets2)]``; ``max_cycles`` means it
    never failed.
    """
    robot = as_robot(robot)
    z_star = np.asarray(z_star, float)
    if replay == "open_loop" and times is None:
        times = cycle_times(gait, z_star, robot=robot, integrator=integrator)
    out = np.zeros((len(offsets1), len(offsets2)), np.int32)
    for i, a in enumerate(offsets1):
        for j, b in enumerate(offsets2):
            z0 = z_star.copy()
            z0[-2:] += (float(a), float(b))
            run = sequence_cycles(gait, z0, cycles=max_cycles, robot=robot,
                                  integrator=integrator, replay=replay, times=times,
                                  reference=z_star, tick=tick, max_drop=max_drop)
            bad = np.flatnonzero(~(run.error <= error_bound))
            out[i, j] = int(bad[0]) if bad.size else len(run.error)
    return out


__all__ = ["REPLAYS", "SequenceCycles", "cycle_error", "cycle_times", "motorless",
           "open_loop_gait", "section_error", "section_watch", "sequence_basin",
           "sequence_cycles"]
