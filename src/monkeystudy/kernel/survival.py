"""Survival runs (compiled): a gait run cycle after cycle under noise until it fails.

:func:`survival_runs` runs a block of independent runs of one controller program. Each cycle
of each run is one call of the hybrid loop (:func:`~monkeystudy.kernel.hybrid.simulate_loop`)
on a copy of the program whose rows carry that cycle's noise; the run goes on from the hybrid
state the call leaves, so with zero noise a run is bit for bit the deterministic multi-cycle run.

Noise (scales in the vector layout ``NZ_*``, each 0 when off), drawn per action and per
cycle from :mod:`~monkeystudy.kernel.noise` under the key ``(seed, run, cycle, slot)``:

* timing jitter [s]: a row whose exit is an actuation (``RL_JITTER``) exits ``d`` later:
  a time guard's instant moves by ``d`` (either sign), a state guard's action waits ``|d|``
  after the guard fires (a latency cannot be negative);
* actuation latency [s]: one draw per run, uniform on ``[0, scale)``, added to the delay of
  every actuation (the time an actuator takes to act, the same on every action of a build);
* sensor noise: a row's guard value moves by a draw of the source it reads (``RL_SENSOR``:
  an angle [rad], a rate [rad s-1], a height [m] or an energy [J]), held for that action;
* torque error: a motor pulse's torque is multiplied by ``1 + e`` (``RL_PULSE``);
* initial state: the section state's ``theta2``, ``dtheta1``, ``dtheta2`` once per run;
* bar spacing [m]: one draw per run, added to every bar's horizontal distance from the end
  the robot hangs from (``S_BAR_DX``, its sign kept): the run's ladder is spaced that much
  wider (or narrower) than the gait's. A bar is the world's, not a sensor's: no jitter, no
  latency; the catch snaps the hook onto the run's bar.

Program row ``k`` of cycle ``c`` draws slots ``3k`` (jitter), ``3k + 1`` (sensor), ``3k + 2``
(torque); the initial state draws slots 0-2, the latency slot :data:`LATENCY_SLOT` and the bar
spacing slot :data:`BAR_SPACING_SLOT` on the cycle word ``PER_RUN_CYCLE``.

A cycle is measured where it ends: at the last observer crossing it logged (the exact
section, e.g. link 1 at the vertical), else at the exit of its cycle-ending row. A run fails
at the first cycle whose call stops with a status other than ok (fell, no swap, ...), whose
error against the reference exceeds the bound (``ST_ERROR_BOUND``), or whose horizontal
advance of the attached end is less than the minimum (``ST_STALLED``: it stopped travelling).
A run's height (``SV_HEIGHT``) is measured from its planned height: the start's, plus the
program's rise (``S_RISE``) per completed cycle.
"""
import math

import numpy as np

from .hybrid import simulate_loop
from .jit import njit
from .layout import (
    C_MAX_CYCLES, DTH1, DTH2, G_BAR, H_CYCLES, H_SEG, H_T, JITTER_LATENCY, JITTER_NONE, K_LOG,
    K_NFEV, L_KIND, L_STATE, L_T, LOG_OBSERVER, N_COUNTS, N_HYB, N_LOG_COLS, N_MODE_COLS,
    NZ_BAR_SPACING, NZ_DTHETA1, NZ_DTHETA2, NZ_LATENCY, NZ_THETA2, NZ_TIMING, NZ_TORQUE,
    NZ_UNIFORM, RL_JITTER, RL_PULSE, RL_SENSOR, S_BAR_DX, S_DELAY, S_GUARD, S_GVALUE, S_NEXT,
    S_RISE, S_TORQUE, ST_ERROR_BOUND, ST_OK, ST_STALLED, SV_CYCLES, SV_DISTANCE, SV_ERROR,
    SV_FAILURE, SV_HEIGHT, SV_NFEV, SV_TIME, TH2, X, Y,
)
from .noise import PER_RUN_CYCLE, standard_draw

#: event-log rows one cycle may use (segment exits, observer crossings, friction changes)
CYCLE_LOG_ROWS = 256
#: the per-run draw of the actuation latency (cycle word PER_RUN_CYCLE)
LATENCY_SLOT = 22
#: the per-run draw of the ladder's spacing error (cycle word PER_RUN_CYCLE)
BAR_SPACING_SLOT = 23


@njit(cache=True, error_model="numpy")
def wrapped_error(s8, z_ref):
    """Section error of a frame state against ``z_ref = (theta2, dtheta1, dtheta2)``:
    ``wrap(theta2 - theta2_ref)^2 + (dtheta1 - dtheta1_ref)^2 + (dtheta2 - dtheta2_ref)^2``."""
    d = (s8[TH2] - z_ref[0] + math.pi) % (2.0 * math.pi) - math.pi
    return d * d + (s8[DTH1] - z_ref[1]) ** 2 + (s8[DTH2] - z_ref[2]) ** 2


@njit(cache=True, error_model="numpy")
def noisy_program(prog, roles, noise, seed, run, cycle, latency, bar_error, out):
    """Write cycle ``cycle``'s program of run ``run`` into ``out`` (rows as ``prog`` with the
    cycle's delays, guard values and torques; ``latency`` [s] the run's actuation latency,
    ``bar_error`` [m] its ladder's spacing error, added to each bar's distance)."""
    uniform = noise[NZ_UNIFORM] > 0.0
    timing = noise[NZ_TIMING]
    torque = noise[NZ_TORQUE]
    for k in range(prog.shape[0]):
        for j in range(prog.shape[1]):
            out[k, j] = prog[k, j]
        jitter = int(roles[k, RL_JITTER])
        if jitter != JITTER_NONE and timing > 0.0:
            d = timing * standard_draw(seed, run, cycle, 3 * k, uniform)
            out[k, S_DELAY] = abs(d) if jitter == JITTER_LATENCY else d
        if jitter != JITTER_NONE and latency > 0.0:
            out[k, S_DELAY] += latency
        source = int(roles[k, RL_SENSOR])
        if source > 0 and noise[source] > 0.0:
            out[k, S_GVALUE] = prog[k, S_GVALUE] + noise[source] * standard_draw(
                seed, run, cycle, 3 * k + 1, uniform)
        if roles[k, RL_PULSE] > 0.0 and torque > 0.0:
            out[k, S_TORQUE] = prog[k, S_TORQUE] * (1.0 + torque * standard_draw(
                seed, run, cycle, 3 * k + 2, uniform))
        if bar_error != 0.0 and int(prog[k, S_GUARD]) == G_BAR:
            # away from the attached end, whichever way the ladder runs
            out[k, S_BAR_DX] = prog[k, S_BAR_DX] + math.copysign(1.0, prog[k, S_BAR_DX]) * \
                bar_error


@njit(cache=True, error_model="numpy")
def survival_run(method, par, prog, obs, settings, hyb0, roles, noise, seed, run, z_ref,
                 max_cycles, error_bound, min_advance, travel, out):
    """One run of up to ``max_cycles`` cycles from the hybrid state ``hyb0`` (a section
    state: the reference ``z_ref`` plus the run's initial-state noise); writes its outcome
    (layout ``SV_*``) into ``out``.

    ``error_bound`` [rad2 + rad2 s-2] and ``min_advance`` [m per cycle] are the failure
    bounds (inf, -inf: off); the advance is measured along ``travel`` (+1.0: world +x,
    -1.0: world -x, the way the gait goes). ``par`` are the run's robot parameters (its own
    draw of the uncertain ones), ``settings`` the run settings (``C_MAX_CYCLES`` is set per
    cycle here), ``roles`` the noise role of each program row (layout ``RL_*``), ``noise``
    the scales (``NZ_*``).
    """
    uniform = noise[NZ_UNIFORM] > 0.0
    hyb = hyb0.copy()
    for i, source in ((TH2, NZ_THETA2), (DTH1, NZ_DTHETA1), (DTH2, NZ_DTHETA2)):
        if noise[source] > 0.0:
            hyb[i] += noise[source] * standard_draw(seed, run, PER_RUN_CYCLE, i - TH2, uniform)
    x_start = hyb[X]
    y_start = hyb[Y]
    latency = 0.0
    if noise[NZ_LATENCY] > 0.0:    # uniform on [0, scale): a draw on [-1, 1) mapped there
        latency = noise[NZ_LATENCY] * 0.5 * (
            standard_draw(seed, run, PER_RUN_CYCLE, LATENCY_SLOT, True) + 1.0)
    bar_error = 0.0
    if noise[NZ_BAR_SPACING] > 0.0:
        bar_error = noise[NZ_BAR_SPACING] * standard_draw(seed, run, PER_RUN_CYCLE,
                                                          BAR_SPACING_SLOT, uniform)
    run_settings = settings.copy()
    cycle_prog = np.empty_like(prog)
    counts = np.zeros(N_COUNTS, dtype=np.int64)
    seg_times = np.empty(prog.shape[0])
    # the loop's batch of one run: views of the same arrays
    hyb_rows = hyb.reshape((1, N_HYB))
    counts_rows = counts.reshape((1, N_COUNTS))
    seg_rows = seg_times.reshape((1, prog.shape[0]))
    log = np.empty((CYCLE_LOG_ROWS, N_LOG_COLS))
    no_t = np.empty(0)
    no_y = np.empty((0, 8))
    no_mode = np.empty((0, N_MODE_COLS))
    out[SV_CYCLES] = 0.0
    out[SV_FAILURE] = ST_OK
    out[SV_DISTANCE] = 0.0
    out[SV_TIME] = hyb[H_T]
    out[SV_ERROR] = wrapped_error(hyb, z_ref)
    out[SV_HEIGHT] = 0.0
    nfev = 0
    for c in range(max_cycles):
        noisy_program(prog, roles, noise, seed, run, c, latency, bar_error, cycle_prog)
        run_settings[C_MAX_CYCLES] = hyb[H_CYCLES] + 1.0
        counts[K_LOG] = 0
        status = simulate_loop(method, par, cycle_prog, obs, run_settings, hyb_rows,
                               counts_rows, seg_rows, log, no_t, no_y, no_mode)
        nfev += counts[K_NFEV]
        counts[K_NFEV] = 0
        if status != ST_OK:
            out[SV_FAILURE] = status
            break
        n_log = int(counts[K_LOG])
        row = n_log - 1                      # the cycle-ending exit
        for r in range(n_log - 1, -1, -1):
            if log[r, L_KIND] == LOG_OBSERVER:
                row = r
                break
        s8 = log[row, L_STATE:L_STATE + 8]
        err = wrapped_error(s8, z_ref)
        if not err <= error_bound:
            out[SV_FAILURE] = ST_ERROR_BOUND
            break
        if not travel * (s8[X] - x_start - out[SV_DISTANCE]) >= min_advance:
            out[SV_FAILURE] = ST_STALLED
            break
        out[SV_CYCLES] = c + 1.0
        out[SV_DISTANCE] = s8[X] - x_start
        drift = s8[Y] - y_start
        rise = prog[int(hyb[H_SEG]), S_RISE]
        if rise != 0.0:
            # against the route's staircase: the planned height of the cycles completed
            drift = drift - hyb[H_CYCLES] * rise
        out[SV_HEIGHT] = drift
        out[SV_TIME] = log[row, L_T]
        out[SV_ERROR] = err
        # the call stopped on the cycle-ending row, before the next row's entry actions
        hyb[H_SEG] = prog[int(hyb[H_SEG]), S_NEXT]
    out[SV_NFEV] = nfev


@njit(cache=True, error_model="numpy")
def survival_runs(method, par_runs, prog, obs, settings, hyb0, roles, noise, seed, runs, z_ref,
                  max_cycles, error_bound, min_advance, travel, out):
    """:func:`survival_run` for run numbers ``runs[i]`` with parameters ``par_runs[i]``;
    outcomes in ``out[i]`` (layout ``SV_*``). The run number keys the noise, so a run's
    outcome does not depend on the block it is in."""
    for i in range(runs.shape[0]):
        survival_run(method, par_runs[i], prog, obs, settings, hyb0, roles, noise, seed,
                     int(runs[i]), z_ref, max_cycles, error_bound, min_advance, travel, out[i])
