"""Euler-Lagrange equations of the MonkeyBot derived with sympy from docs/model.md section 1.

Only the *positions* of section 1 are typed in (with ``cos`` in the y coordinates, docs/model.md
section 5); the mass matrix, Coriolis/centrifugal vector and gravity vector are derived:

    K = 1/2 (m1 |v_CG1|^2 + m2 |v_CG2|^2 + I1 w1^2 + I2 (w1 + w2)^2 + Ir w_rotor^2),
    V = g (m1 y_CG1 + m2 y_CG2)
    M = d^2 K / d qdot^2,   C qdot = (d (M qdot) / dq) qdot - dK/dq,   G = dV/dq

Flight (q = [x, y, th1, th2]) and swing (q = [th1, th2], x and y constant) are derived
separately. The derivation takes a few seconds: :func:`derivation` caches it per process.

Parameters are passed as ``prm = (m1, m2, L1, L2, r1, r2, I1, I2, g, sigma1, sigma2, Ir, N,
housing1)``: ``sigma_i`` is link i's CG offset across the line between its joints,
counter-clockwise positive (docs/model.md section 1), 0 for in-line links; ``Ir`` the joint
motor's rotor inertia, ``N`` its gear ratio and ``housing1`` 1 when its housing is on link 1,
0 when on link 2. The rotor turns at ``w_rotor``: its housing link's rate plus ``N`` times the
other link's rate relative to it, ``w1 + N w2`` or ``(w1 + w2) - N w2``.
"""
from __future__ import annotations

import functools
from types import SimpleNamespace

import sympy as sp

PARAM_NAMES = ("m1", "m2", "L1", "L2", "r1", "r2", "I1", "I2", "g", "sigma1", "sigma2", "Ir",
               "N", "housing1")


def _positions(x, y, th1, th2, L1, r1, L2, r2, sigma1, sigma2):
    """docs/model.md section 1, typed in verbatim."""
    cg1 = sp.Matrix([x + r1 * sp.sin(th1) + sigma1 * sp.cos(th1),
                     y - r1 * sp.cos(th1) + sigma1 * sp.sin(th1)])
    joint = sp.Matrix([x + L1 * sp.sin(th1), y - L1 * sp.cos(th1)])
    cg2 = sp.Matrix([x + L1 * sp.sin(th1) + r2 * sp.sin(th1 + th2) + sigma2 * sp.cos(th1 + th2),
                     y - L1 * sp.cos(th1) - r2 * sp.cos(th1 + th2)
                     + sigma2 * sp.sin(th1 + th2)])
    b = sp.Matrix([x + L1 * sp.sin(th1) + L2 * sp.sin(th1 + th2),
                   y - L1 * sp.cos(th1) - L2 * sp.cos(th1 + th2)])
    return cg1, joint, cg2, b


def _euler_lagrange(K, V, q, qd):
    """``M``, ``C qdot`` and ``G`` of ``L = K - V`` with ``K`` quadratic in ``qd``."""
    qv = sp.Matrix(q)
    qdv = sp.Matrix(qd)
    M = sp.hessian(K, qd)
    p = M * qdv                                       # generalized momenta dK/dqdot
    Cq = p.jacobian(qv) * qdv - sp.Matrix([sp.diff(K, qi) for qi in q])
    G = sp.Matrix([sp.diff(V, qi) for qi in q])
    return M, Cq, G


@functools.lru_cache(maxsize=1)
def derivation() -> SimpleNamespace:
    """Symbolic flight and swing systems and their numpy lambdas (cached)."""
    x, y, th1, th2 = sp.symbols("x y theta1 theta2", real=True)
    dx, dy, w1, w2 = sp.symbols("dx dy w1 w2", real=True)
    m1, m2, L1, L2, r1, r2, I1, I2, g = sp.symbols(" ".join(PARAM_NAMES[:9]), positive=True)
    sigma1, sigma2, Ir, N, housing1 = sp.symbols(" ".join(PARAM_NAMES[9:]), real=True)
    prm = (m1, m2, L1, L2, r1, r2, I1, I2, g, sigma1, sigma2, Ir, N, housing1)

    cg1, joint, cg2, b = _positions(x, y, th1, th2, L1, r1, L2, r2, sigma1, sigma2)

    def energies(q, qd):
        Jv1 = cg1.jacobian(sp.Matrix(q))
        Jv2 = cg2.jacobian(sp.Matrix(q))
        v1 = Jv1 * sp.Matrix(qd)
        v2 = Jv2 * sp.Matrix(qd)
        # angular velocities from the angles themselves (w1 and w1 + w2 in both systems)
        om1 = w1
        om2 = w1 + w2
        om_rotor = housing1 * (om1 + N * w2) + (1 - housing1) * (om2 - N * w2)
        K = sp.Rational(1, 2) * (m1 * v1.dot(v1) + m2 * v2.dot(v2) + I1 * om1 ** 2
                                 + I2 * om2 ** 2 + Ir * om_rotor ** 2)
        V = g * (m1 * cg1[1] + m2 * cg2[1])
        return sp.expand(K), V

    # flight: q = [x, y, th1, th2]
    qf = [x, y, th1, th2]
    qdf = [dx, dy, w1, w2]
    Kf, Vf = energies(qf, qdf)
    Mf, Cf, Gf = _euler_lagrange(Kf, Vf, qf, qdf)
    # swing: q = [th1, th2], (x, y) constant
    qs = [th1, th2]
    qds = [w1, w2]
    Ks, Vs = energies(qs, qds)
    Ms, Cs, Gs = _euler_lagrange(Ks, Vs, qs, qds)

    # momenta (for the conservation tests): linear momentum and angular momentum about a point
    px, py = sp.symbols("px py", real=True)
    v1 = cg1.jacobian(sp.Matrix(qf)) * sp.Matrix(qdf)
    v2 = cg2.jacobian(sp.Matrix(qf)) * sp.Matrix(qdf)
    lin = m1 * v1 + m2 * v2
    cross = lambda r, v: r[0] * v[1] - r[1] * v[0]  # noqa: E731
    ang_terms = sp.Matrix([m1 * cross(cg1 - sp.Matrix([px, py]), v1),
                           m2 * cross(cg2 - sp.Matrix([px, py]), v2),
                           I1 * w1, I2 * (w1 + w2),
                           Ir * (housing1 * (w1 + N * w2) + (1 - housing1) * (w1 + w2 - N * w2))])
    ang = sum(ang_terms)
    cg = (m1 * cg1 + m2 * cg2) / (m1 + m2)

    args_f = (qf, qdf, prm)
    args_s = (qs, qds, prm)
    lam = functools.partial(sp.lambdify, modules="numpy", cse=True)
    ns = SimpleNamespace(
        symbols=SimpleNamespace(q=qf, qd=qdf, prm=prm),
        M_flight=Mf, Cq_flight=Cf, G_flight=Gf, M_swing=Ms, Cq_swing=Cs, G_swing=Gs,
        K_flight=Kf, V_flight=Vf,
        f_M_flight=lam(args_f, Mf), f_Cq_flight=lam(args_f, Cf), f_G_flight=lam(args_f, Gf),
        f_M_swing=lam(args_s, Ms), f_Cq_swing=lam(args_s, Cs), f_G_swing=lam(args_s, Gs),
        f_K=lam(args_f, Kf), f_V=lam(args_f, Vf),
        f_points=lam(args_f, sp.Matrix([[qf[0], qf[1]], [cg1[0], cg1[1]],
                                        [joint[0], joint[1]], [cg2[0], cg2[1]],
                                        [b[0], b[1]]])),
        f_lin_momentum=lam(args_f, lin),
        f_ang_momentum=sp.lambdify((qf, qdf, prm, (px, py)), ang, modules="numpy", cse=True),
        # its four terms (links' orbital and spin parts): their magnitudes give a scale
        f_ang_momentum_terms=sp.lambdify((qf, qdf, prm, (px, py)), ang_terms, modules="numpy",
                                         cse=True),
        f_cg=lam(args_f, cg),
    )
    return ns
