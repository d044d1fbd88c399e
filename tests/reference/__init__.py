"""An independent reference MonkeyBot for the kernel tests.

Nothing here imports :mod:`monkeystudy.kernel`: the equations of motion are derived from the
Lagrangian of docs/model.md section 1 with sympy (:mod:`.symbolic`), the impact is the
explicit projection matrix of section 3, and the hybrid runs are chained
``scipy.integrate.solve_ivp`` calls with terminal events (:mod:`.model`).
"""
