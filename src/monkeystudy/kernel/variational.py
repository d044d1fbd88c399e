"""Variational equations of the swing phase and Jacobians of the resets (compiled).

Derivatives are taken by complex step, ``f'(x) = Im f(x + i h) / h`` with ``h = 1e-30``: no
subtraction, so they are exact to round-off, and they differentiate the very functions the
simulator integrates (no second copy of the equations to drift out of step).

Swing states are packed ``y = [theta1, theta2, dtheta1, dtheta2]``; a variational state is
``Y = [y (4), Phi (16, row-major)]`` with ``dPhi/dt = A(y) Phi``, ``A = df/dy``.
"""
import numpy as np
from numba import njit

from .dynamics import (
    attach_xy_end, flip_state, kinetic_energy, potential_energy, rhs_swing, swing_accel,
)

#: the swing vector field, under the name the variational code reads best with
swing_field = rhs_swing

CSTEP = 1e-30


@njit(cache=True)
def swing_jacobian(p, tau, fmode, y, A):
    """``A[i, j] = d f_i / d y_j`` of the swing field (complex step, exact to round-off)."""
    z = np.empty(4, dtype=np.complex128)
    for j in range(4):
        for i in range(4):
            z[i] = y[i]
        z[j] += 1j * CSTEP
        a1, a2 = swing_accel(p, tau, fmode, z[0], z[1], z[2], z[3])
        A[0, j] = 1.0 if j == 2 else 0.0
        A[1, j] = 1.0 if j == 3 else 0.0
        A[2, j] = a1.imag / CSTEP
        A[3, j] = a2.imag / CSTEP


@njit(cache=True)
def swing_variational_rhs(p, tau, fmode, Y, dY):
    """Augmented field: ``dY[:4] = f(y)``, ``dPhi = A(y) Phi``."""
    A = np.empty((4, 4))
    rhs_swing(p, tau, fmode, Y[:4], dY[:4])
    swing_jacobian(p, tau, fmode, Y[:4], A)
    for i in range(4):
        for j in range(4):
            acc = 0.0
            for k in range(4):
                acc += A[i, k] * Y[4 + 4 * k + j]
            dY[4 + 4 * i + j] = acc


@njit(cache=True)
def _swap(p_before, p_after, y):
    """Swing state after a magnet swap (embed, flip, project; MODEL.md section 3)."""
    s8 = np.zeros(8, dtype=y.dtype)
    s8[2] = y[0]
    s8[3] = y[1]
    s8[6] = y[2]
    s8[7] = y[3]
    flip_state(p_before, s8)
    attach_xy_end(p_after, s8)
    out = np.empty(4, dtype=y.dtype)
    out[0] = s8[2]
    out[1] = s8[3]
    out[2] = s8[6]
    out[3] = s8[7]
    return out


@njit(cache=True)
def swap_state(p_before, p_after, y):
    """The swap as a map on packed swing states (float)."""
    return _swap(p_before, p_after, y)


@njit(cache=True)
def swap_jacobian(p_before, p_after, y, J):
    """Jacobian of :func:`swap_state` (complex step): flip and plastic impact together."""
    z = np.empty(4, dtype=np.complex128)
    for j in range(4):
        for i in range(4):
            z[i] = y[i]
        z[j] += 1j * CSTEP
        out = _swap(p_before, p_after, z)
        for i in range(4):
            J[i, j] = out[i].imag / CSTEP


@njit(cache=True)
def swing_energy_gradient(p, y_end, y, g):
    """Gradient of the total energy (attached end at height ``y_end``) w.r.t. packed ``y``."""
    for j in range(4):
        z = np.empty(4, dtype=np.complex128)
        for i in range(4):
            z[i] = y[i]
        z[j] += 1j * CSTEP
        e = kinetic_energy(p, z[0], z[1], 0.0, 0.0, z[2], z[3]) + \
            potential_energy(p, y_end, z[0], z[1])
        g[j] = e.imag / CSTEP
