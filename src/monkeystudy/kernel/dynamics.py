"""The robot's model (the room): state layout, equations of motion, energy, kinematics, impact
and flip of the MonkeyBot (compiled).

Everything that is the two-link robot is here, and no other kernel module reads its
parameters: the guards, the generated steps and the hybrid loop reach it through the
functions below, named in :data:`MODEL_KERNELS`; :data:`TWO_LINK` is the model the loop is
built on (docs/architecture.md, "The robot's model").

Every sine and cosine is :func:`.trig.sincos`, one definition (the guards' energies and heights
then equal those of :func:`total_energy8` and :func:`free_end_offset` bit for bit). It also
accepts complex arguments: :mod:`.variational` differentiates the vector fields, energies, flip
and impact by complex step, exactly to round-off.

Pure ``@njit(cache=True)`` functions on float64 arrays (but the two that build parameter
rows, which only Python calls); parameter rows follow :mod:`monkeystudy.kernel.layout`.
Equation references are to docs/model.md.

Integration vectors are packed per phase:

* swing  (2-DOF): ``[theta1, theta2, dtheta1, dtheta2]``, the attached end fixed at a pivot
  carried beside the vector;
* flight (4-DOF): ``[x, y, theta1, theta2, dx, dy, dtheta1, dtheta2]``.

A link's centre of gravity may lie off the line between its joints (``P_S1``, ``P_S2``,
docs/model.md section 1): each term it adds is appended after the in-line ones, so for in-line
links it is an exact zero and every in-line value keeps its bits (with or without floating-point
contraction: a fused multiply-add of an exact zero product returns its addend).

Friction (docs/model.md section 2, "Generalized forces") is viscous ``-b w`` plus Coulomb
``-c sgn(w)``. The Coulomb sign is *not* evaluated from the state: it is the slip direction
``fmode[k]`` held constant by the hybrid loop between located zero-speed events, so the vector
field is smooth inside every integration step. ``fmode[k] == 0`` means the DOF is stuck
(locked: its acceleration is zero and the friction supplies the holding torque).
``fmode[0]`` is the pivot (theta1, swing only), ``fmode[1]`` the joint (theta2).
"""
import math

import numpy as np

from .jit import Model, njit
from .layout import (
    FLIES, P_A, P_AS, P_B_JOINT, P_B_PIVOT, P_C_JOINT, P_C_PIVOT, P_G, P_H, P_HS, P_I1, P_I2,
    P_GEAR, P_HOUSING1, P_J11, P_J12, P_J22, P_K11, P_K22, P_L1, P_L2, P_M1, P_M2, P_M2R2,
    P_M2S2, P_MTOT, P_R1, P_R2, P_ROTOR, P_S1, P_S2, PHASE_SWING, PHASE_FLIGHT, T_C1,
    T_C12, T_C2, T_S1, T_S12, T_S2,
)
from .trig import sincos

TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------------------------------------
# parameters
# ----------------------------------------------------------------------------------------------
def derive_params(p):
    """Fill the derived slots of a parameter row in place (docs/model.md section 2 shorthand).

    Plain Python, like :func:`flipped_params`: only :meth:`monkeystudy.Robot.params` calls
    them, once per robot, so compiling them would only lengthen a first run (before its gait
    evaluation can start compiling); the same products and sums in the same order give the
    same bits.
    """
    m1, m2, L1, r1, r2 = p[P_M1], p[P_M2], p[P_L1], p[P_R1], p[P_R2]
    sigma1, sigma2 = p[P_S1], p[P_S2]
    p[P_A] = m1 * r1 + m2 * L1
    p[P_H] = m2 * r2 * L1
    p[P_M2R2] = m2 * r2
    # the across-offsets' squares last: exact zeros for in-line links
    p[P_K11] = (p[P_I1] + p[P_I2] + m1 * r1 * r1 + m2 * L1 * L1 + m2 * r2 * r2
                + m1 * sigma1 * sigma1 + m2 * sigma2 * sigma2)
    p[P_K22] = p[P_I2] + m2 * r2 * r2 + m2 * sigma2 * sigma2
    p[P_MTOT] = m1 + m2
    p[P_AS] = m1 * sigma1
    p[P_HS] = m2 * sigma2 * L1
    p[P_M2S2] = m2 * sigma2
    # the rotor turns with its housing's link plus gear ratio times the other link's angle
    # relative to that link: w1 + N w2 (housing on link 1) or (w1 + w2) - N w2 (on link 2)
    rate = p[P_GEAR] if p[P_HOUSING1] == 1.0 else 1.0 - p[P_GEAR]
    p[P_J11] = p[P_ROTOR]
    p[P_J12] = rate * p[P_ROTOR]
    p[P_J22] = rate * rate * p[P_ROTOR]


def flipped_params(p):
    """Parameters of the same robot described from the other end (docs/model.md section 3).

    Links swap roles; CG distances are re-measured from the new proximal ends
    (``r1' = L2 - r2``, ``r2' = L1 - r1``) and each link's direction reverses, so its
    across-offset changes sign (``sigma1' = -sigma2``, ``sigma2' = -sigma1``; ``0 - x``: an
    in-line link keeps ``+0.0``). Friction belongs to the pivot and the joint, not to a link,
    so it is unchanged; the motor's housing stays on its link, which changes number.
    """
    q = np.array(p, dtype=np.float64)
    q[P_M1], q[P_M2] = p[P_M2], p[P_M1]
    q[P_L1], q[P_L2] = p[P_L2], p[P_L1]
    q[P_I1], q[P_I2] = p[P_I2], p[P_I1]
    q[P_R1] = p[P_L2] - p[P_R2]
    q[P_R2] = p[P_L1] - p[P_R1]
    q[P_S1] = 0.0 - p[P_S2]
    q[P_S2] = 0.0 - p[P_S1]
    q[P_HOUSING1] = 1.0 - p[P_HOUSING1]
    derive_params(q)
    return q


# ----------------------------------------------------------------------------------------------
# state layout per phase: the full 8-state (layout ``X`` .. ``DTH2``) and the packed vectors
# the integrator steps (module docstring); nothing else maps one to the other
# ----------------------------------------------------------------------------------------------
#: the packed vectors as the generated Runge-Kutta steps take them (tools/gen_rk_kernels.py
#: writes kernel/rk_explicit.py from these): the length ``n``, the slots of the positions and
#: of their rates (a position's derivative is its rate, read from the stage), and the field
#: ``accel`` (this module's ``<accel>_fused`` and ``<accel>_trig_fused``) with the slots it
#: takes, the angles then their rates; the accelerations are the derivatives of ``vel``
PACKED_SWING = {"n": 4, "pos": [0, 1], "vel": [2, 3], "accel": "swing_accel",
                "args": (0, 1, 2, 3)}
PACKED_FLIGHT = {"n": 8, "pos": [0, 1, 2, 3], "vel": [4, 5, 6, 7], "accel": "flight_accel",
                 "args": (2, 3, 6, 7)}


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def unpack(phase, y, pivot):
    """Full 8-state ``(x, y, th1, th2, dx, dy, dth1, dth2)`` from a packed vector."""
    if phase == PHASE_FLIGHT:
        return y[0], y[1], y[2], y[3], y[4], y[5], y[6], y[7]
    return pivot[0], pivot[1], y[0], y[1], 0.0, 0.0, y[2], y[3]


@njit(cache=True, error_model="numpy", _nrt=False)
def pack(phase, s8, y):
    """Packed integration vector of a phase from a full 8-state; returns its length."""
    if phase == PHASE_FLIGHT:
        for i in range(8):
            y[i] = s8[i]
        return 8
    y[0] = s8[2]
    y[1] = s8[3]
    y[2] = s8[6]
    y[3] = s8[7]
    return 4


@njit(cache=True, error_model="numpy", _nrt=False)
def unpack_into(phase, y, pivot, s8):
    """The full 8-state of a packed vector (:func:`unpack`) into ``s8``."""
    x, yy, th1, th2, vx, vy, w1, w2 = unpack(phase, y, pivot)
    s8[0] = x
    s8[1] = yy
    s8[2] = th1
    s8[3] = th2
    s8[4] = vx
    s8[5] = vy
    s8[6] = w1
    s8[7] = w2


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def trig_of(phase, y, trig):
    """Sines and cosines of a packed state's angles into ``trig`` (layout ``T_*``)."""
    if phase == PHASE_FLIGHT:
        th1 = y[2]
        th2 = y[3]
    else:
        th1 = y[0]
        th2 = y[1]
    s1, c1, s2, c2, s12, c12 = angle_trig(th1, th2)
    trig[T_S1] = s1
    trig[T_C1] = c1
    trig[T_S2] = s2
    trig[T_C2] = c2
    trig[T_S12] = s12
    trig[T_C12] = c12


# ----------------------------------------------------------------------------------------------
# equations of motion
# ----------------------------------------------------------------------------------------------
@njit(cache=True, inline="always", error_model="numpy")
def _field_trig(th1, th2):
    """``(s1, c1, s2, c2, s12, c12)`` for the vector fields, the sum angle from the identity.

    A sine beside the cosine of the same angle is one :func:`.trig.sincos` (one reduction), so
    the fields need two instead of three. The
    identity's absolute error, ~1 ulp of the products, is below that of ``sin`` of the rounded
    sum ``theta1 + theta2``. (The guards take the sum angle directly: :func:`angle_trig`.)
    """
    s1, c1 = sincos(th1)
    s2, c2 = sincos(th2)
    return s1, c1, s2, c2, s1 * c2 + c1 * s2, c1 * c2 - s1 * s2


@njit(cache=True, inline="always", error_model="numpy")
def angle_trig(th1, th2):
    """``(s1, c1, s2, c2, s12, c12)`` with the sum angle taken directly (layout ``T_*``).

    The one definition of the sines and cosines the guards see: the step's last stage
    (:func:`swing_accel_trig`, :func:`flight_accel_trig`) and :func:`trig_of` both
    use it, so they agree bit for bit.
    """
    s1, c1 = sincos(th1)
    s2, c2 = sincos(th2)
    s12, c12 = sincos(th1 + th2)
    return s1, c1, s2, c2, s12, c12


@njit(cache=True, inline="always", error_model="numpy")
def _swing_terms(p, tau, fmode, th1, th2, w1, w2):
    """Swing mass matrix entries and right-hand side ``F - C qdot - G`` (docs/model.md section 2)."""
    s1, c1, s2, c2, s12, c12 = _field_trig(th1, th2)
    return _swing_terms_t(p, tau, fmode, s1, c1, s2, c2, s12, c12, w1, w2)


@njit(cache=True, inline="always", error_model="numpy")
def _swing_terms_t(p, tau, fmode, s1, c1, s2, c2, s12, c12, w1, w2):
    """:func:`_swing_terms` from the sines and cosines of the angles."""
    h = p[P_H]
    hs = p[P_HS]
    # link 2's moment about the joint along and across the link, in the derivative of the
    # mass matrix: h s2 + hs c2 (hs = 0 for an in-line link 2)
    hs2 = h * s2 + hs * c2
    gm2r2s12 = p[P_G] * p[P_M2R2] * s12 + p[P_G] * p[P_M2S2] * c12
    m11 = p[P_K11] + 2.0 * h * c2 - 2.0 * hs * s2 + p[P_J11]
    m12 = p[P_K22] + h * c2 - hs * s2 + p[P_J12]
    m22 = p[P_K22] + p[P_J22]
    # the term in s12 last: it waits on both angles' sines and cosines (the identity of
    # _field_trig), the latest operand of a stage, so the other terms are summed meanwhile
    r1 = (hs2 * (2.0 * w1 * w2 + w2 * w2) - p[P_G] * p[P_A] * s1
          - p[P_B_PIVOT] * w1 - p[P_C_PIVOT] * fmode[0] - p[P_G] * p[P_AS] * c1) - gm2r2s12
    r2 = (-hs2 * w1 * w1 + tau - p[P_B_JOINT] * w2 - p[P_C_JOINT] * fmode[1]) - gm2r2s12
    return m11, m12, m22, r1, r2


@njit(cache=True, inline="always", error_model="numpy")
def _solve2(m11, m12, m22, r1, r2, lock1, lock2):
    """Solve the symmetric 2x2 system, with locked DOFs held at zero acceleration."""
    if lock1 and lock2:
        return 0.0, 0.0
    if lock1:
        return 0.0, r2 / m22
    if lock2:
        return r1 / m11, 0.0
    # the reciprocal of the determinant needs only the mass matrix (cos theta2), known before
    # the right-hand side (sin(theta1 + theta2)): divided meanwhile, then two products
    inv_det = 1.0 / (m11 * m22 - m12 * m12)
    return (m22 * r1 - m12 * r2) * inv_det, (m11 * r2 - m12 * r1) * inv_det


@njit(cache=True, inline="always", error_model="numpy")
def _flight_coupling(p, th1, th2):
    """Off-diagonal block of the flight mass matrix, rows (x, y), columns (theta1, theta2)."""
    s1, c1 = sincos(th1)
    s12, c12 = sincos(th1 + th2)
    return _flight_coupling_t(p, c1, s1, c12, s12)


@njit(cache=True, inline="always", error_model="numpy")
def _flight_coupling_t(p, c1, s1, c12, s12):
    """:func:`_flight_coupling` from the sines and cosines of the angles."""
    a = p[P_A]
    m2r2 = p[P_M2R2]
    a_s = p[P_AS]
    m2s2 = p[P_M2S2]
    return (a * c1 + m2r2 * c12 - a_s * s1 - m2s2 * s12, m2r2 * c12 - m2s2 * s12,
            a * s1 + m2r2 * s12 + a_s * c1 + m2s2 * c12, m2r2 * s12 + m2s2 * c12,
            c1, s1, c12, s12)


@njit(cache=True, inline="always", error_model="numpy")
def swing_accel(p, tau, fmode, th1, th2, w1, w2):
    """Swing (2-DOF) accelerations ``(ddtheta1, ddtheta2)`` [rad s-2], docs/model.md section 2."""
    m11, m12, m22, r1, r2 = _swing_terms(p, tau, fmode, th1, th2, w1, w2)
    return _solve2(m11, m12, m22, r1, r2, fmode[0] == 0.0, fmode[1] == 0.0)


@njit(cache=True, inline="always", error_model="numpy")
def swing_accel_trig(p, tau, fmode, th1, th2, w1, w2):
    """:func:`swing_accel` and ``(s1, c1, s2, c2, s12, c12)``, the sines and cosines of
    ``theta1``, ``theta2`` and ``theta1 + theta2`` (layout ``T_*``).

    For the last stage of a step: the guards at the new point need these very values
    (:func:`angle_trig`, the sum angle taken directly, not by the identity of
    :func:`_field_trig`), and a cosine beside a sine of the same angle costs little (one
    :func:`.trig.sincos`).
    """
    s1, c1, s2, c2, s12, c12 = angle_trig(th1, th2)
    m11, m12, m22, r1, r2 = _swing_terms_t(p, tau, fmode, s1, c1, s2, c2, s12, c12, w1, w2)
    a1, a2 = _solve2(m11, m12, m22, r1, r2, fmode[0] == 0.0, fmode[1] == 0.0)
    return a1, a2, s1, c1, s2, c2, s12, c12


@njit(cache=True, inline="always", error_model="numpy")
def flight_accel(p, tau, fmode, th1, th2, w1, w2):
    """Free-flight (4-DOF) accelerations ``(ddx, ddy, ddtheta1, ddtheta2)``, docs/model.md section 2.

    Solved by a Schur complement on the (x, y) block, whose mass block is ``(m1+m2) I``:
    exact, and cheaper than a general 4x4 factorisation. The position of the (x, y) end and
    its velocity do not enter (translation invariance).
    """
    s1, c1, s2, c2, s12, c12 = _field_trig(th1, th2)
    return _flight_accel_t(p, tau, fmode, s1, c1, s2, c2, s12, c12, w1, w2)


@njit(cache=True, inline="always", error_model="numpy")
def flight_accel_trig(p, tau, fmode, th1, th2, w1, w2):
    """:func:`flight_accel` and the sines and cosines of the angles (see
    :func:`swing_accel_trig`)."""
    s1, c1, s2, c2, s12, c12 = angle_trig(th1, th2)
    ax, ay, a1, a2 = _flight_accel_t(p, tau, fmode, s1, c1, s2, c2, s12, c12, w1, w2)
    return ax, ay, a1, a2, s1, c1, s2, c2, s12, c12


# The fields of the Runge-Kutta steps, each compiled once as its own function with the steps'
# flags (floating-point contraction, no reference counting) and inlined by LLVM into every
# stage. Numba's own inlining (``inline="always"``) gives the same instructions, but copies and
# re-analyses the field's IR at each of a step's stages, which lengthens the compile of every
# step.
_STEP_FIELD = {"cache": True, "forceinline": True, "fastmath": {"contract"},
               "error_model": "numpy", "_nrt": False}


@njit(**_STEP_FIELD)
def swing_accel_fused(p, tau, fmode, th1, th2, w1, w2):
    """:func:`swing_accel` for the Runge-Kutta steps (contraction allowed)."""
    return swing_accel(p, tau, fmode, th1, th2, w1, w2)


@njit(**_STEP_FIELD)
def swing_accel_trig_fused(p, tau, fmode, th1, th2, w1, w2):
    """:func:`swing_accel_trig` for the Runge-Kutta steps (contraction allowed)."""
    return swing_accel_trig(p, tau, fmode, th1, th2, w1, w2)


@njit(**_STEP_FIELD)
def flight_accel_fused(p, tau, fmode, th1, th2, w1, w2):
    """:func:`flight_accel` for the Runge-Kutta steps (contraction allowed)."""
    return flight_accel(p, tau, fmode, th1, th2, w1, w2)


@njit(**_STEP_FIELD)
def flight_accel_trig_fused(p, tau, fmode, th1, th2, w1, w2):
    """:func:`flight_accel_trig` for the Runge-Kutta steps (contraction allowed)."""
    return flight_accel_trig(p, tau, fmode, th1, th2, w1, w2)


@njit(cache=True, inline="always", error_model="numpy")
def _flight_accel_t(p, tau, fmode, s1, c1, s2, c2, s12, c12, w1, w2):
    """:func:`flight_accel` from the sines and cosines of the angles."""
    b02, b03, b12, b13, _, _, _, _ = _flight_coupling_t(p, c1, s1, c12, s12)
    mt = p[P_MTOT]
    a = p[P_A]
    m2r2 = p[P_M2R2]
    a_s = p[P_AS]
    m2s2 = p[P_M2S2]
    w12 = w1 + w2
    # right-hand side F - C qdot - G; no pivot friction in flight (nothing is pinned)
    rx = a * s1 * w1 * w1 + m2r2 * s12 * w12 * w12 + a_s * c1 * w1 * w1 \
        + m2s2 * c12 * w12 * w12
    ry = -(a * c1 * w1 * w1 + m2r2 * c12 * w12 * w12) - p[P_G] * mt + a_s * s1 * w1 * w1 \
        + m2s2 * s12 * w12 * w12
    h = p[P_H]
    hs = p[P_HS]
    hs2 = h * s2 + hs * c2
    gm2r2s12 = p[P_G] * m2r2 * s12 + p[P_G] * m2s2 * c12
    r1 = hs2 * (2.0 * w1 * w2 + w2 * w2) - p[P_G] * a * s1 - gm2r2s12 - p[P_G] * a_s * c1
    r2 = -hs2 * w1 * w1 - gm2r2s12 + tau - p[P_B_JOINT] * w2 - p[P_C_JOINT] * fmode[1]
    m11 = p[P_K11] + 2.0 * h * c2 - 2.0 * hs * s2 + p[P_J11]
    m12 = p[P_K22] + h * c2 - hs * s2 + p[P_J12]
    m22 = p[P_K22] + p[P_J22]
    # Schur complement S = Ms - B^T B / mt, reduced rhs = r_th - B^T r_xy / mt
    inv_mt = 1.0 / mt
    s11 = m11 - (b02 * b02 + b12 * b12) * inv_mt
    s12_ = m12 - (b02 * b03 + b12 * b13) * inv_mt
    s22 = m22 - (b03 * b03 + b13 * b13) * inv_mt
    q1 = r1 - (b02 * rx + b12 * ry) * inv_mt
    q2 = r2 - (b03 * rx + b13 * ry) * inv_mt
    a1, a2 = _solve2(s11, s12_, s22, q1, q2, False, fmode[1] == 0.0)
    return (rx - b02 * a1 - b03 * a2) * inv_mt, (ry - b12 * a1 - b13 * a2) * inv_mt, a1, a2


@njit(cache=True, error_model="numpy", _nrt=False)
def rhs_swing(p, tau, fmode, y, dy):
    """Swing (2-DOF) vector field, docs/model.md section 2. ``y`` packed swing state."""
    a1, a2 = swing_accel(p, tau, fmode, y[0], y[1], y[2], y[3])
    dy[0] = y[2]
    dy[1] = y[3]
    dy[2] = a1
    dy[3] = a2


@njit(cache=True, error_model="numpy", _nrt=False)
def rhs_flight(p, tau, fmode, y, dy):
    """Free-flight (4-DOF) vector field, docs/model.md section 2. ``y`` packed flight state."""
    ax, ay, a1, a2 = flight_accel(p, tau, fmode, y[2], y[3], y[6], y[7])
    dy[0] = y[4]
    dy[1] = y[5]
    dy[2] = y[6]
    dy[3] = y[7]
    dy[4] = ax
    dy[5] = ay
    dy[6] = a1
    dy[7] = a2


@njit(cache=True, error_model="numpy", _nrt=False)
def rhs(phase, p, tau, fmode, y, dy):
    """Vector field of the current phase (the fixed phase has none: ``dy = 0``).

    The accelerations are inlined, not called through :func:`rhs_swing` / :func:`rhs_flight`:
    a function free of calls lets numba drop the reference counting of its array arguments
    (atomic operations on every call).
    """
    if phase == PHASE_SWING:
        a1, a2 = swing_accel(p, tau, fmode, y[0], y[1], y[2], y[3])
        dy[0] = y[2]
        dy[1] = y[3]
        dy[2] = a1
        dy[3] = a2
    elif FLIES and phase == PHASE_FLIGHT:
        ax, ay, a1, a2 = flight_accel(p, tau, fmode, y[2], y[3], y[6], y[7])
        for i in range(4):
            dy[i] = y[4 + i]
        dy[4] = ax
        dy[5] = ay
        dy[6] = a1
        dy[7] = a2
    else:
        for i in range(dy.shape[0]):
            dy[i] = 0.0


@njit(cache=True, error_model="numpy", _nrt=False)
def holding_torque(phase, p, tau, fmode, y, k):
    """Friction torque that would hold DOF ``k`` (0 pivot, 1 joint) at zero speed [N m].

    DOF ``k`` is locked, its own Coulomb term removed, the other DOF keeps its mode
    (slipping or stuck). Row ``k`` of ``M qddot - (F - C qdot - G)`` is then the torque the
    friction must supply. The hybrid loop sticks when ``|torque| <= c_k`` and otherwise slips
    with sign ``-sgn(torque)``, the direction the unheld DOF starts to move.
    """
    # the friction modes with DOF k's removed, as a pair: nothing allocated, so callers can
    # be compiled without numba's runtime
    fm = (0.0 if k == 0 else fmode[0], 0.0 if k == 1 else fmode[1])
    if phase == PHASE_SWING:
        m11, m12, m22, r1, r2 = _swing_terms(p, tau, fm, y[0], y[1], y[2], y[3])
        a1, a2 = _solve2(m11, m12, m22, r1, r2, fm[0] == 0.0, fm[1] == 0.0)
        if k == 0:
            return m11 * a1 + m12 * a2 - r1
        return m12 * a1 + m22 * a2 - r2
    if FLIES and phase == PHASE_FLIGHT and k == 1:
        th1, th2, w1, w2 = y[2], y[3], y[6], y[7]
        ax, ay, a1, a2 = flight_accel(p, tau, fm, th1, th2, w1, w2)
        b02, b03, b12, b13, c1, s1, c12, s12 = _flight_coupling(p, th1, th2)
        h = p[P_H]
        hs = p[P_HS]
        s2, c2 = sincos(th2)
        r2 = (-(h * s2 + hs * c2) * w1 * w1 - p[P_G] * p[P_M2R2] * s12 + tau
              - p[P_B_JOINT] * w2 - p[P_G] * p[P_M2S2] * c12)
        return (b03 * ax + b13 * ay + (p[P_K22] + h * c2 - hs * s2 + p[P_J12]) * a1
                + (p[P_K22] + p[P_J22]) * a2 - r2)
    return 0.0


# ----------------------------------------------------------------------------------------------
# energy and kinematics (world frame, docs/model.md section 1)
# ----------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy", _nrt=False)
def kinetic_energy(p, th1, th2, vx, vy, w1, w2):
    """Kinetic energy K [J], docs/model.md section 1 (``vx = vy = 0`` while swinging)."""
    s2, c2 = sincos(th2)
    k = kinetic_energy_rot(p, s2, c2, w1, w2)
    if vx != 0.0 or vy != 0.0:
        s1, c1 = sincos(th1)
        s12, c12 = sincos(th1 + th2)
        k += kinetic_energy_trans(p, c1, s1, c12, s12, vx, vy, w1, w2)
    return k


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def kinetic_energy_rot(p, s2, c2, w1, w2):
    """The rotational part of :func:`kinetic_energy` (all of it while swinging) [J]."""
    return kinetic_rot_s(p[P_H], p[P_HS], p[P_K11], p[P_K22], p[P_J11], p[P_J12], p[P_J22],
                         s2, c2, w1, w2)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def kinetic_rot_s(h, hs, k11, k22, j11, j12, j22, s2, c2, w1, w2):
    """:func:`kinetic_energy_rot` from scalars (``P_H``, ``P_HS``, ``P_K11``, ``P_K22``,
    ``P_J11``, ``P_J12``, ``P_J22``)."""
    m11 = k11 + 2.0 * h * c2 - 2.0 * hs * s2 + j11
    m12 = k22 + h * c2 - hs * s2 + j12
    return 0.5 * (m11 * w1 * w1 + 2.0 * m12 * w1 * w2 + (k22 + j22) * w2 * w2)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def kinetic_energy_trans(p, c1, s1, c12, s12, vx, vy, w1, w2):
    """The part of :func:`kinetic_energy` due to the (x, y) end's velocity [J]."""
    return kinetic_trans_s(p[P_A], p[P_AS], p[P_M2R2], p[P_M2S2], p[P_MTOT], c1, s1, c12, s12,
                           vx, vy, w1, w2)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def kinetic_trans_s(a, a_s, m2r2, m2s2, mt, c1, s1, c12, s12, vx, vy, w1, w2):
    """:func:`kinetic_energy_trans` from scalars (``P_A``, ``P_AS``, ``P_M2R2``, ``P_M2S2``,
    ``P_MTOT``); the coupling block as :func:`_flight_coupling_t` forms it."""
    b02 = a * c1 + m2r2 * c12 - a_s * s1 - m2s2 * s12
    b03 = m2r2 * c12 - m2s2 * s12
    b12 = a * s1 + m2r2 * s12 + a_s * c1 + m2s2 * c12
    b13 = m2r2 * s12 + m2s2 * c12
    return 0.5 * mt * (vx * vx + vy * vy) + vx * (b02 * w1 + b03 * w2) \
        + vy * (b12 * w1 + b13 * w2)


@njit(cache=True, error_model="numpy", _nrt=False)
def potential_energy(p, y_end, th1, th2):
    """Potential energy V [J] with the (x, y) end at world height ``y_end`` (docs/model.md section 1)."""
    s1, c1 = sincos(th1)
    s12, c12 = sincos(th1 + th2)
    return potential_energy_t(p, y_end, s1, c1, s12, c12)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def potential_energy_t(p, y_end, s1, c1, s12, c12):
    """:func:`potential_energy` from the sines and cosines of ``theta1`` and
    ``theta1 + theta2`` [J]."""
    return potential_s(p[P_G], p[P_MTOT], p[P_A], p[P_AS], p[P_M2R2], p[P_M2S2], y_end, s1, c1,
                       s12, c12)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def potential_s(g, mt, a, a_s, m2r2, m2s2, y_end, s1, c1, s12, c12):
    """:func:`potential_energy_t` from scalars (``P_G``, ``P_MTOT``, ``P_A``, ``P_AS``,
    ``P_M2R2``, ``P_M2S2``)."""
    return g * (mt * y_end - a * c1 - m2r2 * c12 + a_s * s1 + m2s2 * s12)


@njit(cache=True, error_model="numpy", _nrt=False)
def total_energy8(p, s):
    """Total energy of a full 8-state ``[x, y, th1, th2, dx, dy, dth1, dth2]`` [J]."""
    return kinetic_energy(p, s[2], s[3], s[4], s[5], s[6], s[7]) + \
        potential_energy(p, s[1], s[2], s[3])


@njit(cache=True, error_model="numpy", _nrt=False)
def free_end_offset(p, th1, th2):
    """Position of the free end relative to the (x, y) end [m] (docs/model.md section 1, B)."""
    s1, c1 = sincos(th1)
    s12, c12 = sincos(th1 + th2)
    return p[P_L1] * s1 + p[P_L2] * s12, -p[P_L1] * c1 - p[P_L2] * c12


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def guard_params(p):
    """The parameters the guards read (:mod:`.events`), as scalars, in one straight-line read:
    ``(L1, L2, g, mt, a, a_s, m2r2, m2s2, h, hs, k11, k22, j11, j12, j22, b_joint, c_joint,
    b_pivot, c_pivot)`` (``P_L1``, ``P_L2``, ``P_G``, ``P_MTOT``, ``P_A``, ``P_AS``,
    ``P_M2R2``, ``P_M2S2``, ``P_H``, ``P_HS``, ``P_K11``, ``P_K22``, ``P_J11``, ``P_J12``,
    ``P_J22``, ``P_B_JOINT``, ``P_C_JOINT``, ``P_B_PIVOT``, ``P_C_PIVOT``) [SI]; the guards
    pass them on to the functions below and to the energies' ``*_s`` functions."""
    return (p[P_L1], p[P_L2], p[P_G], p[P_MTOT], p[P_A], p[P_AS], p[P_M2R2], p[P_M2S2],
            p[P_H], p[P_HS], p[P_K11], p[P_K22], p[P_J11], p[P_J12], p[P_J22], p[P_B_JOINT],
            p[P_C_JOINT], p[P_B_PIVOT], p[P_C_PIVOT])


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def free_end_height_s(L1, L2, c1, c12):
    """Height of the free end above the (x, y) end [m], from the link lengths ``L1``, ``L2``
    [m] and the cosines of ``theta1`` and ``theta1 + theta2`` (docs/model.md section 1, B)."""
    return -L1 * c1 - L2 * c12


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def free_end_height_rate_s(L1, L2, s1, s12, w1, w2):
    """Rate of :func:`free_end_height_s` [m s-1], from the sines of ``theta1`` and
    ``theta1 + theta2`` and the rates ``w1``, ``w2`` [rad s-1] of the angles."""
    return L1 * s1 * w1 + L2 * s12 * (w1 + w2)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def free_end_y_s(y_end, L1, L2, c1, c12):
    """World height of the free end [m] with the (x, y) end at height ``y_end`` [m] (see
    :func:`free_end_height_s`; summed from ``y_end``, not added to the height)."""
    return y_end - L1 * c1 - L2 * c12


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def free_end_y_rate_s(vy, L1, L2, s1, s12, w1, w2):
    """Rate of :func:`free_end_y_s` [m s-1] with the (x, y) end rising at ``vy`` [m s-1]."""
    return vy + L1 * s1 * w1 + L2 * s12 * (w1 + w2)


@njit(cache=True, error_model="numpy", _nrt=False)
def points8(p, s, out):
    """World positions of the (x, y) end, CG1, joint, CG2 and the free end: ``out[5, 2]``."""
    x, y, th1, th2 = s[0], s[1], s[2], s[3]
    s1, c1 = sincos(th1)
    s12, c12 = sincos(th1 + th2)
    L1, L2, r1, r2 = p[P_L1], p[P_L2], p[P_R1], p[P_R2]
    sigma1, sigma2 = p[P_S1], p[P_S2]
    out[0, 0], out[0, 1] = x, y
    out[1, 0], out[1, 1] = x + r1 * s1 + sigma1 * c1, y - r1 * c1 + sigma1 * s1
    out[2, 0], out[2, 1] = x + L1 * s1, y - L1 * c1
    out[3, 0] = x + L1 * s1 + r2 * s12 + sigma2 * c12
    out[3, 1] = y - L1 * c1 - r2 * c12 + sigma2 * s12
    out[4, 0], out[4, 1] = x + L1 * s1 + L2 * s12, y - L1 * c1 - L2 * c12


# ----------------------------------------------------------------------------------------------
# matrices (for tests, Floquet work and documentation; the vector fields inline them)
# ----------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy")
def flight_matrices(p, s):
    """Flight ``M`` (4x4), ``C qdot`` (4) and ``G`` (4) at a full 8-state, docs/model.md section 2."""
    th1, th2, w1, w2 = s[2], s[3], s[6], s[7]
    b02, b03, b12, b13, c1, s1, c12, s12 = _flight_coupling(p, th1, th2)
    h, hs = p[P_H], p[P_HS]
    a, a_s, m2r2, m2s2 = p[P_A], p[P_AS], p[P_M2R2], p[P_M2S2]
    s2, c2 = sincos(th2)
    M = np.zeros((4, 4))
    M[0, 0] = M[1, 1] = p[P_MTOT]
    M[0, 2] = M[2, 0] = b02
    M[0, 3] = M[3, 0] = b03
    M[1, 2] = M[2, 1] = b12
    M[1, 3] = M[3, 1] = b13
    M[2, 2] = p[P_K11] + 2.0 * h * c2 - 2.0 * hs * s2 + p[P_J11]
    M[2, 3] = M[3, 2] = p[P_K22] + h * c2 - hs * s2 + p[P_J12]
    M[3, 3] = p[P_K22] + p[P_J22]
    w12 = w1 + w2
    hs2 = h * s2 + hs * c2
    Cq = np.empty(4)
    Cq[0] = -(a * s1 * w1 * w1 + m2r2 * s12 * w12 * w12 + a_s * c1 * w1 * w1
              + m2s2 * c12 * w12 * w12)
    Cq[1] = (a * c1 * w1 * w1 + m2r2 * c12 * w12 * w12 - a_s * s1 * w1 * w1
             - m2s2 * s12 * w12 * w12)
    Cq[2] = -hs2 * (2.0 * w1 * w2 + w2 * w2)
    Cq[3] = hs2 * w1 * w1
    G = np.empty(4)
    G[0] = 0.0
    G[1] = p[P_G] * p[P_MTOT]
    G[2] = p[P_G] * (a * s1 + m2r2 * s12 + a_s * c1 + m2s2 * c12)
    G[3] = p[P_G] * (m2r2 * s12 + m2s2 * c12)
    return M, Cq, G


@njit(cache=True, error_model="numpy")
def swing_matrices(p, th1, th2, w1, w2):
    """Swing ``M`` (2x2) and ``C qdot + G`` (2) at ``(theta1, theta2)`` [rad] and their rates
    [rad s-1], docs/model.md section 2: ``M qddot + (C qdot + G) = [0, tau]`` without friction.
    For tests and documentation (the vector fields inline the same terms)."""
    fm = (1.0, 1.0)      # slipping, so that no friction term is evaluated as a lock
    p0 = p.copy()
    p0[P_B_PIVOT] = p0[P_C_PIVOT] = p0[P_B_JOINT] = p0[P_C_JOINT] = 0.0
    m11, m12, m22, r1, r2 = _swing_terms(p0, 0.0, fm, th1, th2, w1, w2)
    M = np.empty((2, 2))
    M[0, 0] = m11
    M[0, 1] = M[1, 0] = m12
    M[1, 1] = m22
    bias = np.empty(2)
    bias[0] = -r1
    bias[1] = -r2
    return M, bias


@njit(cache=True, error_model="numpy")
def impact_projection(p, s):
    """The plastic-impact projection ``P = I - M^-1 J^T (J M^-1 J^T)^-1 J`` (docs/model.md section 3)."""
    M, Cq, G = flight_matrices(p, s)
    Minv = np.linalg.inv(M)
    J = np.zeros((2, 4))
    J[0, 0] = 1.0
    J[1, 1] = 1.0
    A = J @ Minv @ J.T
    return np.eye(4) - Minv @ J.T @ np.linalg.solve(A, J)


# ----------------------------------------------------------------------------------------------
# impact and flip (docs/model.md section 3)
# ----------------------------------------------------------------------------------------------
@njit(cache=True, error_model="numpy", _nrt=False)
def attach_xy_end(p, s):
    """Plastic impact that pins the (x, y) end: ``qdot+ = P qdot-`` (docs/model.md section 3).

    The impulse acts only on the (x, y) rows, so the (theta1, theta2) rows of ``M qdot`` are
    conserved; with ``dx+ = dy+ = 0`` that gives ``Ms dth+ = Ms dth- + B^T v-``, which is
    exactly ``P qdot-`` (tests check the equality with the explicit projection).
    """
    th1, th2, vx, vy, w1, w2 = s[2], s[3], s[4], s[5], s[6], s[7]
    b02, b03, b12, b13, c1, s1, c12, s12 = _flight_coupling(p, th1, th2)
    h = p[P_H]
    hs = p[P_HS]
    s2, c2 = sincos(th2)
    m11 = p[P_K11] + 2.0 * h * c2 - 2.0 * hs * s2 + p[P_J11]
    m12 = p[P_K22] + h * c2 - hs * s2 + p[P_J12]
    m22 = p[P_K22] + p[P_J22]
    r1 = m11 * w1 + m12 * w2 + b02 * vx + b12 * vy
    r2 = m12 * w1 + m22 * w2 + b03 * vx + b13 * vy
    det = m11 * m22 - m12 * m12
    s[4] = 0.0
    s[5] = 0.0
    s[6] = (m22 * r1 - m12 * r2) / det
    s[7] = (m11 * r2 - m12 * r1) / det


@njit(cache=True, error_model="numpy", _nrt=False)
def wrap_angle(a):
    """Angle in [-pi, pi) (the shift uses the real part, so complex steps pass through)."""
    return a - TWO_PI * math.floor((a.real + math.pi) / TWO_PI)


@njit(cache=True, error_model="numpy", _nrt=False)
def flip_state(p, s):
    """Re-express a full 8-state about the free end, in place (docs/model.md section 3, "flip").

    ``p`` are the parameters of the frame *before* the flip. ``theta1'`` is wrapped to
    [-pi, pi) so that "theta1 crosses 0" keeps meaning "link 1 passes the downward vertical".
    ``theta2' = -theta2`` is not wrapped: the joint angle stays continuous along the motion.
    (Wrapping it made the gait error ``theta2_f^2 + ...`` jump by ~(2 pi)^2 at swaps with the
    links folded, theta2 = +-pi, where round-off picked the branch.)
    """
    x, y, th1, th2, vx, vy, w1, w2 = s[0], s[1], s[2], s[3], s[4], s[5], s[6], s[7]
    L1, L2 = p[P_L1], p[P_L2]
    s1, c1 = sincos(th1)
    s12, c12 = sincos(th1 + th2)
    s[0] = x + L1 * s1 + L2 * s12
    s[1] = y - L1 * c1 - L2 * c12
    s[2] = wrap_angle(math.pi + th1 + th2)
    s[3] = -th2
    s[4] = vx + L1 * c1 * w1 + L2 * c12 * (w1 + w2)
    s[5] = vy + L1 * s1 * w1 + L2 * s12 * (w1 + w2)
    s[6] = w1 + w2
    s[7] = -w2


# ----------------------------------------------------------------------------------------------
# the model: what the hybrid loop is built on (docs/architecture.md, "The robot's model")
# ----------------------------------------------------------------------------------------------
#: the kernels of this module that the hybrid loop and its callees (events, integrate, the
#: generated steps) call, by the names they call them: what a model of the robot provides
MODEL_KERNELS = (
    "pack", "unpack", "unpack_into", "angle_trig", "rhs", "swing_accel_fused",
    "swing_accel_trig_fused", "flight_accel_fused", "flight_accel_trig_fused", "holding_torque",
    "attach_xy_end", "flip_state", "total_energy8", "kinetic_rot_s", "kinetic_trans_s",
    "potential_s", "guard_params", "free_end_height_s", "free_end_height_rate_s", "free_end_y_s",
    "free_end_y_rate_s", "free_end_offset",
)
#: the two-link robot: the model of every hybrid loop unless another is given
TWO_LINK = Model("two_link", {name: globals()[name] for name in MODEL_KERNELS})
