"""The horizontal gait with ``scipy.integrate.solve_ivp``: an independent baseline.

The same gait as the kernel (docs/model.md sections 2-4: swing about A to the swap guard, flip and
plastic impact, motor until the energy is restored, swing to the vertical), written with
chained ``solve_ivp`` calls and terminal events, a hand-written right-hand side (scalar or
numpy) and no code shared with :mod:`monkeystudy.kernel`. The benchmark and the
work-precision study time the kernel against it; tests compare results with it.
"""
from __future__ import annotations

import math

import numpy as np

from ..robot import Robot


class ScipyGait:
    """The horizontal gait with ``scipy.integrate.solve_ivp``; ``rhs`` 'scalar' or 'numpy'."""

    def __init__(self, robot: Robot, torque: float, rhs: str = "scalar"):
        l1, l2 = robot.link1, robot.link2
        self.m1, self.m2, self.L1, self.L2 = l1.mass, l2.mass, l1.length, l2.length
        self.r1, self.r2, self.I1, self.I2 = l1.com, l2.com, l1.inertia, l2.inertia
        self.g = robot.gravity
        self.torque = torque
        self.rhs_kind = rhs

    def params(self, flipped: bool):
        if not flipped:
            return (self.m1, self.m2, self.L1, self.L2, self.r1, self.r2, self.I1, self.I2)
        return (self.m2, self.m1, self.L2, self.L1, self.L2 - self.r2, self.L1 - self.r1,
                self.I2, self.I1)

    def make_rhs(self, prm, tau):
        m1, m2, L1, L2, r1, r2, I1, I2 = prm
        g = self.g
        a = m1 * r1 + m2 * L1
        h = m2 * r2 * L1
        k11 = I1 + I2 + m1 * r1 ** 2 + m2 * L1 ** 2 + m2 * r2 ** 2
        k22 = I2 + m2 * r2 ** 2
        sin, cos = math.sin, math.cos
        if self.rhs_kind == "scalar":
            def f(t, y):
                th1, th2, w1, w2 = y
                s2 = sin(th2)
                c2 = cos(th2)
                s12 = sin(th1 + th2)
                m11 = k11 + 2 * h * c2
                m12 = k22 + h * c2
                q1 = h * s2 * (2 * w1 * w2 + w2 * w2) - g * (a * sin(th1) + m2 * r2 * s12)
                q2 = -h * s2 * w1 * w1 - g * m2 * r2 * s12 + tau
                det = m11 * k22 - m12 * m12
                return [w1, w2, (k22 * q1 - m12 * q2) / det, (m11 * q2 - m12 * q1) / det]
        else:
            def f(t, y):
                th1, th2, w1, w2 = y
                c2 = np.cos(th2)
                s2 = np.sin(th2)
                s12 = np.sin(th1 + th2)
                M = np.array([[k11 + 2 * h * c2, k22 + h * c2], [k22 + h * c2, k22]])
                Cq = np.array([-h * s2 * (2 * w1 * w2 + w2 ** 2), h * s2 * w1 ** 2])
                G = np.array([g * (a * np.sin(th1) + m2 * r2 * s12), g * m2 * r2 * s12])
                acc = np.linalg.solve(M, np.array([0.0, tau]) - Cq - G)
                return np.concatenate(([w1, w2], acc))
        return f

    def energy(self, prm, y_end, th1, th2, w1, w2):
        m1, m2, L1, L2, r1, r2, I1, I2 = prm
        c2 = math.cos(th2)
        h = m2 * r2 * L1
        k11 = I1 + I2 + m1 * r1 ** 2 + m2 * L1 ** 2 + m2 * r2 ** 2
        k22 = I2 + m2 * r2 ** 2
        kin = 0.5 * ((k11 + 2 * h * c2) * w1 ** 2 + 2 * (k22 + h * c2) * w1 * w2 + k22 * w2 ** 2)
        pot = self.g * ((m1 + m2) * y_end - (m1 * r1 + m2 * L1) * math.cos(th1)
                        - m2 * r2 * math.cos(th1 + th2))
        return kin + pot

    def swap(self, prm, y_end, th1, th2, w1, w2):
        """Flip about the free end and project (docs/model.md section 3); returns the new state."""
        m1, m2, L1, L2, r1, r2, I1, I2 = prm
        s1, c1 = math.sin(th1), math.cos(th1)
        s12, c12 = math.sin(th1 + th2), math.cos(th1 + th2)
        vx = L1 * c1 * w1 + L2 * c12 * (w1 + w2)
        vy = L1 * s1 * w1 + L2 * s12 * (w1 + w2)
        y_new = y_end - L1 * c1 - L2 * c12
        t1 = math.atan2(math.sin(math.pi + th1 + th2), math.cos(math.pi + th1 + th2))
        t2 = math.atan2(math.sin(-th2), math.cos(-th2))
        q = np.array([0.0, y_new, t1, t2])
        dq = np.array([vx, vy, w1 + w2, -w2])
        M = self.flight_mass(self.params(True), t1, t2)
        Minv = np.linalg.inv(M)
        J = np.array([[1.0, 0, 0, 0], [0, 1.0, 0, 0]])
        P = np.eye(4) - Minv @ J.T @ np.linalg.solve(J @ Minv @ J.T, J)
        dq = P @ dq
        return q, dq

    def flight_mass(self, prm, th1, th2):
        m1, m2, L1, L2, r1, r2, I1, I2 = prm
        a = m1 * r1 + m2 * L1
        h = m2 * r2 * L1
        c1, s1, c12, s12, c2 = (math.cos(th1), math.sin(th1), math.cos(th1 + th2),
                                math.sin(th1 + th2), math.cos(th2))
        k22 = I2 + m2 * r2 ** 2
        M = np.zeros((4, 4))
        M[0, 0] = M[1, 1] = m1 + m2
        M[0, 2] = M[2, 0] = a * c1 + m2 * r2 * c12
        M[0, 3] = M[3, 0] = m2 * r2 * c12
        M[1, 2] = M[2, 1] = a * s1 + m2 * r2 * s12
        M[1, 3] = M[3, 1] = m2 * r2 * s12
        M[2, 2] = I1 + I2 + m1 * r1 ** 2 + m2 * L1 ** 2 + m2 * r2 ** 2 + 2 * h * c2
        M[2, 3] = M[3, 2] = k22 + h * c2
        M[3, 3] = k22
        return M

    def gait(self, d1, d2, rtol, atol, method="DOP853", max_time=3.0):
        """(error, t_switch, t_motor, t_end, nfev) of the gait; NaNs when it fails."""
        # scipy.integrate loads in ~0.3 s: only a caller that solves pays it
        from scipy.integrate import solve_ivp
        nan = (math.nan,) * 4
        prm = self.params(False)
        L1, L2 = prm[2], prm[3]
        e0 = self.energy(prm, 0.0, 0.0, 0.0, d1, d2)

        def b_height(t, y):
            return -(L1 * math.cos(y[0]) + L2 * math.cos(y[0] + y[1]))
        b_height.terminal, b_height.direction = True, 1
        s1 = solve_ivp(self.make_rhs(prm, 0.0), (0.0, max_time), [0.0, 0.0, d1, d2],
                       method=method, rtol=rtol, atol=atol, events=b_height)
        nfev = s1.nfev
        if not s1.t_events[0].size:
            return nan + (nfev,)
        ts = s1.t_events[0][0]
        th1, th2, w1, w2 = s1.y_events[0][0]
        q, dq = self.swap(prm, 0.0, th1, th2, w1, w2)
        prm2 = self.params(True)
        y_piv = q[1]

        def restored(t, y):
            return self.energy(prm2, y_piv, *y) - e0
        restored.terminal, restored.direction = True, 1
        s2 = solve_ivp(self.make_rhs(prm2, self.torque), (ts, ts + max_time),
                       [q[2], q[3], dq[2], dq[3]], method=method, rtol=rtol, atol=atol,
                       events=restored)
        nfev += s2.nfev
        if not s2.t_events[0].size:
            return nan + (nfev,)
        tm = s2.t_events[0][0]

        def vertical(t, y):
            return y[0]
        vertical.terminal, vertical.direction = True, 0
        s3 = solve_ivp(self.make_rhs(prm2, 0.0), (tm, tm + max_time), s2.y_events[0][0],
                       method=method, rtol=rtol, atol=atol, events=vertical)
        nfev += s3.nfev
        if not s3.t_events[0].size:
            return nan + (nfev,)
        te = s3.t_events[0][0]
        th1, th2, w1, w2 = s3.y_events[0][0]
        err = th2 ** 2 + (d1 - w1) ** 2 + (d2 - w2) ** 2
        return err, ts, tm - ts, te, nfev
