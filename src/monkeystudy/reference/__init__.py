"""Independent reference implementations, for benchmarks and tests: they share no code with
:mod:`monkeystudy.kernel` (:mod:`.scipy_gait`: the horizontal gait with scipy ``solve_ivp``)."""
