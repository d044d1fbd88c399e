"""Variational equations and Jacobians of the resets and guards (compiled).

Derivatives are taken by complex step, ``f'(x) = Im f(x + i h) / h`` with ``h = 1e-30``: no
subtraction, so they are exact to round-off, and they differentiate the very functions the
simulator integrates (no second copy of the equations to drift out of step).

Every phase on the full 8-state ``s = [x, y, theta1, theta2, dx, dy, dtheta1, dtheta2]``
(swinging, ``(x, y)`` and ``(dx, dy)`` stay put), so that transition matrices keep one shape
through swings, flights and stops and every reset is an 8 -> 8 map: the field, its Jacobian,
the segment guards, the holding torque of a stuck DOF (the break-away guard of Coulomb
friction) and the entry magnet actions (used by
:mod:`monkeystudy.analysis.variational` for every gait, the horizontal gait included).
"""
import numpy as np
from .jit import njit

from .dynamics import (
    flight_accel, free_end_offset, holding_torque, rhs_flight, swing_accel, total_energy8,
)
from .hybrid import apply_magnets
from .layout import (
    G_BAR, G_COORD, G_ENERGY, G_ENERGY_RESTORED, G_FREE_END_HEIGHT, G_FREE_END_Y,
    PHASE_FLIGHT, PHASE_SWING,
)

CSTEP = 1e-30


# ----------------------------------------------------------------------------------------------
# any phase on the full 8-state
# ----------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def field8(phase, p, tau, fm, s, f):
    """Vector field of either phase on the full 8-state ``[x, y, th1, th2, dx, dy, dth1,
    dth2]`` (complex-capable).

    Swinging, the (x, y) end is pinned: ``d(x, y)/dt = d(dx, dy)/dt = 0`` (and ``dx = dy = 0``
    on every swing state the resets produce); the fixed phase does not move. ``fm`` are the
    friction modes (:mod:`.dynamics`: the Coulomb slip sign +-1 of the pivot and the joint,
    0 stuck), constant between friction events as in the hybrid loop: viscous friction and a
    slipping DOF's Coulomb torque are part of the field, a stuck DOF has zero acceleration.
    """
    for i in range(8):
        f[i] = 0.0
    if phase == PHASE_SWING:
        a1, a2 = swing_accel(p, tau, fm, s[2], s[3], s[6], s[7])
        f[2] = s[6]
        f[3] = s[7]
        f[6] = a1
        f[7] = a2
    elif phase == PHASE_FLIGHT:
        rhs_flight(p, tau, fm, s, f)   # the flight state is the 8-state itself


@njit(cache=True, error_model="numpy")
def field8_jacobian(phase, p, tau, fm, s, A):
    """``A[i, j] = d f_i / d s_j`` of :func:`field8` in friction modes ``fm`` (complex step,
    exact to round-off).

    The accelerations depend only on (th1, th2, dth1, dth2) (translation invariance), so four
    complex evaluations give every column.
    """
    A[:, :] = 0.0
    if phase != PHASE_SWING and phase != PHASE_FLIGHT:
        return
    z = np.empty(4, dtype=np.complex128)
    cols = (2, 3, 6, 7)
    for k in range(4):
        z[0] = s[2]
        z[1] = s[3]
        z[2] = s[6]
        z[3] = s[7]
        z[k] += 1j * CSTEP
        j = cols[k]
        if phase == PHASE_SWING:
            a1, a2 = swing_accel(p, tau, fm, z[0], z[1], z[2], z[3])
            A[6, j] = a1.imag / CSTEP
            A[7, j] = a2.imag / CSTEP
        else:
            ax, ay, a1, a2 = flight_accel(p, tau, fm, z[0], z[1], z[2], z[3])
            A[4, j] = ax.imag / CSTEP
            A[5, j] = ay.imag / CSTEP
            A[6, j] = a1.imag / CSTEP
            A[7, j] = a2.imag / CSTEP
    A[2, 6] = 1.0
    A[3, 7] = 1.0
    if phase == PHASE_FLIGHT:
        A[0, 4] = 1.0
        A[1, 5] = 1.0


@njit(cache=True, error_model="numpy")
def variational_rhs8(phase, p, tau, fm, Y, dY):
    """Augmented field on ``Y = [s (8), Phi (8 x m, row-major)]``: ``ds = f(s)``,
    ``dPhi = A(s) Phi``, for either phase, in friction modes ``fm``."""
    m = (Y.shape[0] - 8) // 8
    A = np.empty((8, 8))
    # A is sparse (velocity rows are unit entries, positions never enter): skip its zeros
    field8(phase, p, tau, fm, Y[:8], dY[:8])
    field8_jacobian(phase, p, tau, fm, Y[:8], A)
    for i in range(8):
        for j in range(m):
            acc = 0.0
            for k in range(8):
                if A[i, k] != 0.0:
                    acc += A[i, k] * Y[8 + m * k + j]
            dY[8 + m * i + j] = acc


@njit(cache=True, error_model="numpy")
def guard8(kind, index, value, p, s, eref):
    """A segment guard on the full 8-state, as :func:`.events.guard` computes it, from the
    8-state so that complex steps pass through (``G_TIME`` and ``G_NONE`` are not state
    guards: 0, typed like ``s`` so that every branch returns the same type)."""
    if kind == G_FREE_END_HEIGHT or kind == G_BAR:
        # a bar's guard is the free end's height less the bar's rise (its window and snap
        # are the loop's and the reset's)
        return free_end_offset(p, s[2], s[3])[1] - value
    if kind == G_ENERGY_RESTORED:
        return total_energy8(p, s) - eref - value
    if kind == G_ENERGY:
        return total_energy8(p, s) - value
    if kind == G_FREE_END_Y:
        return s[1] + free_end_offset(p, s[2], s[3])[1] - value
    if kind == G_COORD:
        return s[index] - value
    return 0.0 * s[0]


@njit(cache=True, error_model="numpy")
def guard8_gradient(kind, index, value, p, s, eref, grad):
    """Gradient of :func:`guard8` w.r.t. the 8-state (complex step); ``eref`` held fixed."""
    z = np.empty(8, dtype=np.complex128)
    for j in range(8):
        for i in range(8):
            z[i] = s[i]
        z[j] += 1j * CSTEP
        grad[j] = guard8(kind, index, value, p, z, eref).imag / CSTEP


@njit(cache=True, error_model="numpy")
def holding_torque8(phase, p, tau, fm, s, k):
    """:func:`.dynamics.holding_torque` of friction DOF ``k`` (0 pivot, 1 joint) from the
    full 8-state [N m] (complex-capable): the torque the friction must supply to hold DOF
    ``k`` at zero speed, the other DOF in its mode ``fm``."""
    if phase == PHASE_SWING:
        y = np.empty(4, dtype=s.dtype)
        y[0] = s[2]
        y[1] = s[3]
        y[2] = s[6]
        y[3] = s[7]
        return holding_torque(phase, p, tau, fm, y, k)
    # the flight state is the 8-state itself; the fixed phase holds with no friction
    return holding_torque(phase, p, tau, fm, s.copy(), k)


@njit(cache=True, error_model="numpy")
def holding_torque8_gradient(phase, p, tau, fm, s, k, grad):
    """Gradient of :func:`holding_torque8` w.r.t. the 8-state [N m per unit of each state
    component] (complex step)."""
    z = np.empty(8, dtype=np.complex128)
    for j in range(8):
        for i in range(8):
            z[i] = s[i]
        z[j] += 1j * CSTEP
        grad[j] = holding_torque8(phase, p, tau, fm, z, k).imag / CSTEP


@njit(cache=True, error_model="numpy")
def energy8_gradient(p, s, grad):
    """Gradient of the total energy (:func:`.dynamics.total_energy8`) w.r.t. the 8-state."""
    z = np.empty(8, dtype=np.complex128)
    for j in range(8):
        for i in range(8):
            z[i] = s[i]
        z[j] += 1j * CSTEP
        grad[j] = total_energy8(p, z).imag / CSTEP


@njit(cache=True, error_model="numpy")
def entry_reset(par, s, phase, flipped, mag_a, mag_b, swap, out, DR):
    """Entry magnet actions as a map on 8-states and its Jacobian (complex step).

    Runs :func:`.hybrid.apply_magnets` itself (flip, plastic impact, stops) on a copy:
    ``out`` the state after, ``DR[i, j] = d out_i / d s_j``. Returns the new
    ``(phase, flipped)``. A flip wraps theta1 by a shift taken from the real part
    (:func:`.dynamics.wrap_angle`), so its derivative is 1 on either branch.
    """
    for i in range(8):
        out[i] = s[i]
    ph, fl = apply_magnets(par, out, phase, flipped, mag_a, mag_b, swap)
    z = np.empty(8, dtype=np.complex128)
    for j in range(8):
        for i in range(8):
            z[i] = s[i]
        z[j] += 1j * CSTEP
        apply_magnets(par, z, phase, flipped, mag_a, mag_b, swap)
        for i in range(8):
            DR[i, j] = z[i].imag / CSTEP
    return ph, fl
