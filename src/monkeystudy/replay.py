"""Many cycles of a sequence gait: its own controller or the 2009 study's open-loop replay.

The 2009 study replayed its gaits open-loop (swap and motor at fixed times after the vertical
crossing) and watched them drift. A sequence gait (:class:`~monkeystudy.controllers.
SequenceGait`) can be run two ways from its fixed point:

- ``replay="gait"``: the controller as written, state guards and all (the map whose Floquet
  multipliers the floquet step computes);
- ``replay="open_loop"``: every segment before the section ends at the time it ended on the
  recorded cycle, counted on the controller clock, which restarts at each section crossing
  (the study's ``reset_at_vertical``; :func:`open_loop_gait`). Entry actions (magnets, motor,
  energy latch) are kept; only the guards become clocks.

Either way a controller tick (``tick`` [s]) delays each ticked guard to the next tick, so the
same functions answer "was it the 1 ms grid?" for any sequence gait. Per cycle everything is
measured where the cycle ends, on the section, in the frame of the end attached there: the
section error against the start (the :class:`~monkeystudy.controllers.SequenceGait` error),
the kinetic energy, the attached end's world position. Everything runs through
:func:`monkeystudy.simulate.run_controller`: nothing here integrates on its own.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .analysis import TIGHT, check_cycle_frame, cycle_section_state
from .controllers import Integrator, SequenceGait
from .kernel import layout as L
from .simulate import RobotLike, RunResult, Status, as_robot, energies, evaluate_cycle_gaits, \
    run_controller

#: the two ways of running a sequence gait for many cycles
REPLAYS = ("gait", "open_loop")


def section_error(states: np.ndarray, z) -> np.ndarray:
    """Section error of frame states ``[..., 8]`` against ``z = (theta2 [rad], dtheta1,
    dtheta2 [rad s-1])``: ``wrap(theta2_f - theta2)^2 + (dtheta1_f - dtheta1)^2 + (dtheta2_f -
    dtheta2)^2`` (MODEL.md section 4 generalised; :class:`SequenceGait`) [1]."""
    s = np.asarray(states, float)
    th2, w1, w2 = (float(v) for v in z)
    d = (s[..., L.TH2] - th2 + math.pi) % (2.0 * math.pi) - math.pi  # kernel's wrap
    return d * d + (s[..., L.DTH1] - w1) ** 2 + (s[..., L.DTH2] - w2) ** 2


def cycle_times(gait: SequenceGait, z, *, robot: RobotLike = "seed2009",
                integrator: Integrator = TIGHT) -> np.ndarray:
    """Exit time [s] of each segment of one cycle from section state ``z`` (the section's
    last), on the controller clock from the cycle start. ``ValueError`` if the cycle does not
    close (its status is not ok)."""
    g = replace(gait, theta2=float(z[0]))
    r = evaluate_cycle_gaits([[float(z[1]), float(z[2])]], g, robot=robot,
                             integrator=integrator)
    if int(r["status"][0]) != L.ST_OK:
        raise ValueError(f"the cycle from {tuple(float(v) for v in z)} does not close: "
                         f"{L.STATUS_NAMES[int(r['status'][0])]}")
    return r["t_segment"][0].copy()


def open_loop_gait(gait: SequenceGait, segment_times) -> SequenceGait:
    """The gait with every segment before the section ending at a fixed time.

    ``segment_times`` [s]: the exit times on the controller clock (which restarts at each
    section crossing), e.g. :func:`cycle_times` of the fixed point (the section's own entry,
    if given, is ignored). Entry actions are kept; each guard becomes a ticked ``time`` guard,
    so a controller tick rounds the times up to its grid, as the 2009 study's 1 ms loop did.
    """
    times = np.asarray(segment_times, float).ravel()
    n = len(gait.segments)
    if times.size < n or not np.all(np.isfinite(times[:n])):
        raise ValueError(f"need {n} finite segment exit times, got {times[:n]}")
    if np.any(np.diff(np.concatenate([[0.0], times[:n]])) < 0.0):
        raise ValueError(f"segment exit times must not decrease: {times[:n]}")
    for k, s in enumerate(gait.segments):
        if s.clock != "keep":
            raise ValueError(f"segment {k} moves the controller clock (clock={s.clock!r}): "
                             "recorded times would be on a different clock")
    segs = tuple(replace(s, until="time", value=float(t), ticked=True, direction="rising")
                 for s, t in zip(gait.segments, times[:n]))
    return replace(gait, segments=segs)


@dataclass
class SequenceCycles:
    """Per-cycle record of a multi-cycle run of a sequence gait (arrays over the cycles that
    reached the section; ``run`` is the raw :class:`~monkeystudy.simulate.RunResult`)."""

    error: np.ndarray            # section error vs the start [1]
    kinetic_energy: np.ndarray   # [J] at each section crossing
    pivot_height: np.ndarray     # [m] world height of the attached end at the crossing
    x_advance: np.ndarray        # [m] attached end's horizontal displacement in the cycle
    t_cross: np.ndarray          # [s] section crossing ending the cycle
    t_swap: np.ndarray           # [s] the cycle's first magnet action (NaN: none)
    section_state: np.ndarray    # (n, 8) frame state at each crossing
    status: Status
    run: RunResult


def _magnet_rows(gait: SequenceGait) -> np.ndarray:
    """Rows whose exit enters a segment that acts on the magnets."""
    segs = gait.all_segments()
    n = len(segs)
    return np.array([k for k in range(n) if segs[(k + 1) % n].magnets != "keep"], int)


def sequence_cycles(gait: SequenceGait, z0, *, cycles: int, robot: RobotLike = "seed2009",
                    integrator: Integrator = TIGHT, replay: str = "gait",
                    times=None, reference=None, tick: float | None = None,
                    tick_phase: float = 0.0, max_drop: float | None = None,
                    sample_dt: float = 0.0) -> SequenceCycles:
    """Run a sequence gait for ``cycles`` cycles from section state ``z0 = (theta2 [rad],
    dtheta1, dtheta2 [rad s-1])``, hanging from A at the origin.

    Parameters
    ----------
    replay : {"gait", "open_loop"}
        The gait's own controller, or its open-loop replay (:func:`open_loop_gait`) with the
        segment exit ``times`` [s] (default: :func:`cycle_times` at ``reference``).
    reference : array_like, optional
        The gait the error is measured against (default ``z0``), e.g. the fixed point when
        ``z0`` is a perturbed start.
    tick, tick_phase : float, optional
        Controller tick and its phase [s] (default: the gait's).
    max_drop : float, optional
        Stop with status ``fell`` when the attached end sinks this far [m] below the start
        (default: link 1's length).
    sample_dt : float
        Record the trajectory every ``sample_dt`` [s] (0: none).

    Returns
    -------
    SequenceCycles
        Per cycle that reached the section (ends at a fall, a missed guard or the horizon:
        ``status``). A cycle ending on B needs mirror-image links (``ValueError``).
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
    run_gait = replace(run_gait, theta2=float(z0[0]),
                       tick=gait.tick if tick is None else float(tick),
                       tick_phase=gait.tick_phase if tick is None else float(tick_phase))
    if max_drop is None:
        max_drop = robot.link1.length
    n_rows = len(run_gait.all_segments())
    res = run_controller(run_gait.controller(), cycle_section_state(run_gait, z0), robot=robot,
                         integrator=integrator, cycles=int(cycles), max_drop=float(max_drop),
                         sample_dt=sample_dt, log_capacity=(n_rows + 2) * int(cycles) + 16)
    log = res.log
    seg_rows = log[log[:, L.L_KIND] == L.LOG_SEGMENT]
    cross = seg_rows[seg_rows[:, L.L_ID] == n_rows - 1]
    states = cross[:, L.L_STATE:L.L_STATE + 8].copy()
    flipped = cross[:, L.L_FLIPPED]
    ke, _ = energies(res.params, states, flipped)
    x_prev = np.concatenate([[0.0], states[:-1, L.X]])
    swaps = seg_rows[np.isin(seg_rows[:, L.L_ID].astype(int), _magnet_rows(run_gait))]
    t_start = np.concatenate([[-math.inf], cross[:-1, L.L_T]])
    t_swap = np.full(len(cross), math.nan)
    for c in range(len(cross)):
        k = np.flatnonzero((swaps[:, L.L_T] > t_start[c]) & (swaps[:, L.L_T] <= cross[c, L.L_T]))
        if k.size:
            t_swap[c] = swaps[k[0], L.L_T]
    return SequenceCycles(section_error(states, ref), ke, states[:, L.Y].copy(),
                          states[:, L.X] - x_prev, cross[:, L.L_T].copy(), t_swap, states,
                          Status(int(res.status)), res)


def sequence_basin(gait: SequenceGait, z_star, offsets1, offsets2, *, max_cycles: int = 60,
                   error_bound: float = 1e-2, robot: RobotLike = "seed2009",
                   integrator: Integrator = TIGHT, replay: str = "gait",
                   tick: float | None = None, max_drop: float | None = None) -> np.ndarray:
    """Cycles a sequence gait survives from perturbed starts (a basin map).

    Start ``z_star + (0, a, b)`` for ``a`` in ``offsets1``, ``b`` in ``offsets2`` [rad s-1];
    a run fails at the first section crossing whose error against ``z_star`` exceeds
    ``error_bound``, or when it falls or stops before. The open-loop replay keeps the fixed
    point's times for every start. Returns int ``[len(offsets1), len(offsets2)]``;
    ``max_cycles`` means it never failed.
    """
    robot = as_robot(robot)
    z_star = np.asarray(z_star, float)
    times = cycle_times(gait, z_star, robot=robot, integrator=integrator) \
        if replay == "open_loop" else None
    out = np.zeros((len(offsets1), len(offsets2)), np.int32)
    for i, a in enumerate(offsets1):
        for j, b in enumerate(offsets2):
            z0 = z_star + np.array([0.0, float(a), float(b)])
            run = sequence_cycles(gait, z0, cycles=max_cycles, robot=robot,
                                  integrator=integrator, replay=replay, times=times,
                                  reference=z_star, tick=tick, max_drop=max_drop)
            bad = np.flatnonzero(~(run.error <= error_bound))
            out[i, j] = int(bad[0]) if bad.size else len(run.error)
    return out


__all__ = ["REPLAYS", "SequenceCycles", "cycle_times", "open_loop_gait", "section_error",
           "sequence_basin", "sequence_cycles"]
