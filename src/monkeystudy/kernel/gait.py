"""Gait evaluations: the horizontal gait of docs/model.md section 4 and the cycle of any
phase-sequence gait, one point or a batch.

All run the hybrid loop of :func:`monkeystudy.kernel.hybrid.simulate` with a zero-size log and
trajectory, so a search evaluation integrates, locates its events and nothing else.

Numba links a copy of the loop into every separately compiled function that calls it, directly
or not, and optimises and emits that copy's machine code again on a first run.
So the cycle of a sequence gait, which every study's first run evaluates, is a batch of the
loop itself (:func:`cycle_gait_batch`, array operations around one call of the compiled loop),
and the compiled horizontal-gait evaluation calls the loop directly
(:func:`~monkeystudy.kernel.hybrid.simulate_loop`), its helpers (:func:`simulate_unlogged`,
:func:`_gait_run`) inlined (``inline="always"``).
"""
import math

import numpy as np

from .dynamics import total_energy8
from .hybrid import simulate, simulate_loop
from .jit import njit
from .layout import (
    DTH1, DTH2, H_CLOCK, H_EREF, H_FLIPPED, H_FMODE0, H_FMODE1, H_PHASE, H_SEG, H_T, H_Y_REF,
    K_NFEV, K_REJECTED, K_STATUS, K_STEPS, N_COUNTS, N_HYB, N_LOG_COLS, N_MODE_COLS,
    N_OBS_COLS, PHASE_SWING, ST_OK, ST_UNREACHABLE, TH1, TH2,
)

# result columns of one gait evaluation
R_ERROR, R_STATUS, R_T_SWITCH, R_T_MOTOR, R_T_END = 0, 1, 2, 3, 4
R_STEPS, R_NFEV, R_REJECTED = 5, 6, 7
R_FINAL = 8  # final 8-state (frame after the swap)
N_RESULT = 16


@njit(cache=True, error_model="numpy", _nrt=False)
def start_state(dtheta1, dtheta2, hyb):
    """Hybrid state of a gait start: hanging from A at theta = 0, A at the origin."""
    hyb[:] = 0.0
    hyb[6] = dtheta1
    hyb[7] = dtheta2
    hyb[H_T] = 0.0
    hyb[H_PHASE] = PHASE_SWING
    hyb[H_FLIPPED] = 0
    hyb[H_SEG] = 0
    hyb[H_EREF] = np.nan
    hyb[H_CLOCK] = 0.0
    hyb[H_FMODE0] = 1.0
    hyb[H_FMODE1] = 1.0
    hyb[H_Y_REF] = np.nan


@njit(cache=True, error_model="numpy")
def search_scratch(n_segments):
    """Work arrays of one search evaluation, allocated once per batch, not once per point:
    the hybrid state, the counters, the segment exit times, and the
    zero-size observers, event log and trajectory of a run that records nothing."""
    return (np.empty(N_HYB), np.zeros(N_COUNTS, dtype=np.int64), np.empty(n_segments),
            np.empty((0, N_OBS_COLS)), np.empty((0, N_LOG_COLS)), np.empty(0), np.empty((0, 8)),
            np.empty((0, N_MODE_COLS)))


@njit(cache=True, inline="always", error_model="numpy")
def simulate_unlogged(method, par, prog, obs, settings, scratch):
    """:func:`~monkeystudy.kernel.hybrid.simulate` from the hybrid state ``scratch[0]`` with
    no event log and no trajectory (what a search needs: the outcome, the segment exit times
    in ``scratch[2]`` and the counts in ``scratch[1]``, zeroed here). Inlined into its callers
    (module docstring)."""
    hyb, counts, seg_times, _, no_log, no_t, no_y, no_mode = scratch
    counts[:] = 0
    return simulate_loop(method, par, prog, obs, settings, hyb.reshape((1, N_HYB)),
                         counts.reshape((1, N_COUNTS)),
                         seg_times.reshape((1, seg_times.shape[0])), no_log, no_t, no_y,
                         no_mode)


@njit(cache=True, error_model="numpy")
def horizontal_gait(method, par, prog, settings, dtheta1, dtheta2, energy_floor, skip_unreachable,
                    out):
    """Evaluate the horizontal gait at ``(dtheta1, dtheta2)`` [rad s-1] into ``out``.

    The error (docs/model.md section 4) is ``theta2_f^2 + (dtheta1 - dtheta1_f)^2 +
    (dtheta2 - dtheta2_f)^2`` at the vertical crossing ending the gait; NaN unless the status
    is ``ST_OK``. With ``skip_unreachable``, a start whose total energy is below
    ``energy_floor`` (the least potential energy on the swap surface, :meth:`Robot.
    swap_energy_floor`) is marked ``ST_UNREACHABLE`` without integrating: with the motor off,
    energy cannot grow before the swap.
    """
    scratch = search_scratch(prog.shape[0])
    if not _gait_start(par, dtheta1, dtheta2, energy_floor, skip_unreachable, scratch[0], out):
        _gait_run(method, par, prog, settings, dtheta1, dtheta2, out, scratch)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def _gait_start(par, dtheta1, dtheta2, energy_floor, skip_unreachable, hyb, out):
    """The start state into ``hyb``, ``out`` cleared; True if the start is marked unreachable
    (then ``out`` is complete)."""
    start_state(dtheta1, dtheta2, hyb)
    out[:] = np.nan
    out[R_STEPS] = 0.0
    out[R_NFEV] = 0.0
    out[R_REJECTED] = 0.0
    if skip_unreachable:
        e0 = total_energy8(par[0], hyb)
        if e0 < energy_floor - 1e-12 * (1.0 + abs(energy_floor)):
            out[R_STATUS] = ST_UNREACHABLE
            return True
    return False


@njit(cache=True, inline="always", error_model="numpy")
def _gait_run(method, par, prog, settings, dtheta1, dtheta2, out, scratch):
    """Integrate the gait from the start state in ``scratch[0]`` and fill ``out`` (inlined into
    its callers: module docstring)."""
    hyb, counts, seg_times, no_obs = scratch[0], scratch[1], scratch[2], scratch[3]
    status = simulate_unlogged(method, par, prog, no_obs, settings, scratch)
    out[R_STATUS] = status
    out[R_T_SWITCH] = seg_times[0]
    out[R_T_MOTOR] = seg_times[1] - seg_times[0]
    out[R_T_END] = seg_times[2]
    out[R_STEPS] = counts[K_STEPS]
    out[R_NFEV] = counts[K_NFEV]
    out[R_REJECTED] = counts[K_REJECTED]
    for i in range(8):
        out[R_FINAL + i] = hyb[i]
    if status == ST_OK:
        th2 = hyb[3]
        out[R_ERROR] = th2 * th2 + (dtheta1 - hyb[6]) ** 2 + (dtheta2 - hyb[7]) ** 2


@njit(cache=True, error_model="numpy")
def horizontal_gait_batch(method, par, prog, settings, points, energy_floor, skip_unreachable,
                          out):
    """:func:`horizontal_gait` over ``points[N, 2]`` into ``out[N, N_RESULT]`` (serial)."""
    scratch = search_scratch(prog.shape[0])
    hyb = scratch[0]
    for i in range(points.shape[0]):
        # the start checked before the call that passes the scratch tuple: marking an
        # unreachable start then costs no call
        if not _gait_start(par, points[i, 0], points[i, 1], energy_floor, skip_unreachable,
                           hyb, out[i]):
            _gait_run(method, par, prog, settings, points[i, 0], points[i, 1], out[i], scratch)


# result columns of one cycle of a phase-sequence gait
Q_ERROR, Q_STATUS, Q_T_END, Q_STEPS, Q_NFEV, Q_REJECTED, Q_FLIPPED, Q_PHASE = 0, 1, 2, 3, 4, 5, 6, 7
Q_FINAL = 8  # final 8-state in the frame of the end attached at the section
N_CYCLE_RESULT = 16


@njit(cache=True, error_model="numpy", _nrt=False)
def wrapped_difference(a, b):
    """``a - b`` wrapped to [-pi, pi) [rad]: a link turning a whole revolution per cycle
    returns to the same configuration."""
    return (a - b + math.pi) % (2.0 * math.pi) - math.pi


# wrapped_difference's own Python body, which numpy evaluates on arrays with the same
# operations (its compile takes scalars; interpreted, the function is its own body)
_wrapped_difference_of_arrays = getattr(wrapped_difference, "py_func", wrapped_difference)


def cycle_gait_batch(method, par, prog, obs, settings, theta1, theta2, points, out, seg_out):
    """One cycle of a phase-sequence gait from each section state of ``points[N, 2]`` into
    ``out[N, N_CYCLE_RESULT]`` and ``seg_out[N, n_segments]``.

    Each starts hanging from A at the origin with ``(theta1, theta2)`` [rad] and rates
    ``points[i] = (dtheta1, dtheta2)`` [rad s-1]; runs ``prog`` until it completes one cycle
    (the caller sets ``C_MAX_CYCLES = 1``). The section error generalises docs/model.md
    section 4's: ``wrap(theta2_f - theta2)^2 + (dtheta1_f - dtheta1)^2 + (dtheta2_f -
    dtheta2)^2`` in the frame of the end attached at the cycle's end (NaN unless ``ST_OK``);
    ``seg_out[i, k]`` is the time segment ``k`` was left [s] (NaN if never).

    Not compiled: the points are one batch of the compiled loop
    (:func:`~monkeystudy.kernel.hybrid.simulate`), and the starts and the errors are array
    operations around it. A compiled caller would link the loop again and emit its machine
    code again in a first run's compile.
    """
    n = points.shape[0]
    start = np.empty(N_HYB)
    start_state(0.0, 0.0, start)
    hyb = np.repeat(start[None], n, axis=0)
    hyb[:, DTH1] = points[:, 0]
    hyb[:, DTH2] = points[:, 1]
    hyb[:, TH1] = theta1
    hyb[:, TH2] = theta2
    counts = np.zeros((n, N_COUNTS), dtype=np.int64)
    simulate(method, par, prog, obs, settings, hyb, counts, seg_out, np.empty((0, N_LOG_COLS)),
             np.empty(0), np.empty((0, 8)), np.empty((0, N_MODE_COLS)))
    status = counts[:, K_STATUS]
    out[:] = np.nan
    out[:, Q_STATUS] = status
    out[:, Q_T_END] = hyb[:, H_T]
    out[:, Q_STEPS] = counts[:, K_STEPS]
    out[:, Q_NFEV] = counts[:, K_NFEV]
    out[:, Q_REJECTED] = counts[:, K_REJECTED]
    out[:, Q_FLIPPED] = hyb[:, H_FLIPPED]
    out[:, Q_PHASE] = hyb[:, H_PHASE]
    out[:, Q_FINAL:Q_FINAL + 8] = hyb[:, :8]
    ok = status == ST_OK
    d2 = _wrapped_difference_of_arrays(hyb[ok, TH2], theta2)
    out[ok, Q_ERROR] = (d2 * d2 + (hyb[ok, DTH1] - points[ok, 0]) ** 2
                        + (hyb[ok, DTH2] - points[ok, 1]) ** 2)
