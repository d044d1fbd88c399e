"""One step of a walked route (compiled): a gait's cycle from wherever the robot is, under the
noise of that step.

A route is walked step by step, and each step may run a different gait (the planner chooses
it from where the robot is). :func:`walk_step` runs one cycle of one program from a hybrid
state, with the noise of :mod:`~monkeystudy.kernel.survival` keyed by ``(seed, run, step)``:
step ``k`` of run ``r`` draws what cycle ``k`` of a survival run ``r`` draws, so a walk that
repeats one gait from its fixed point is that gait's survival run.
"""
import numpy as np

from .hybrid import simulate_loop
from .jit import njit
from .layout import C_MAX_CYCLES, H_CYCLES, N_COUNTS, N_HYB
from .survival import noisy_program


@njit(cache=True, error_model="numpy")
def walk_step(method, par, prog, obs, settings, hyb, roles, noise, seed, run, step, latency,
              counts, log, samp_t, samp_y, samp_mode):
    """Run one cycle of ``prog`` (rows in the kernel's frame, ending on a cycle-ending row)
    from the hybrid state ``hyb`` (updated in place: on return it stands on the cycle-ending
    row, before the next row's entry actions) with run ``run``'s noise of step ``step``.

    ``par`` are the run's robot parameters, ``latency`` [s] its actuation latency (drawn once
    per run), ``noise`` the scales (``NZ_*``); ``counts`` (``N_COUNTS``) receives the call's
    counters and ``log`` its event log (``counts[K_LOG]`` rows). Returns the call's status.
    """
    cycle_prog = np.empty_like(prog)
    noisy_program(prog, roles, noise, seed, run, step, latency, 0.0, cycle_prog)
    run_settings = settings.copy()
    run_settings[C_MAX_CYCLES] = hyb[H_CYCLES] + 1.0
    for k in range(N_COUNTS):
        counts[k] = 0
    seg_times = np.empty(prog.shape[0])
    return simulate_loop(method, par, cycle_prog, obs, run_settings, hyb.reshape((1, N_HYB)),
                         counts.reshape((1, N_COUNTS)), seg_times.reshape((1, prog.shape[0])),
                         log, samp_t, samp_y, samp_mode)
