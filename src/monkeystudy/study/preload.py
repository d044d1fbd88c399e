"""Forkserver preload: import the task functions *and* load their compiled kernels once.

Numba loads a cached function on its first call, in each process. The forkserver imports this
module before forking workers, so loading the kernels here (one tiny gait and one short
open-loop run) means every worker starts with them in memory instead of reading the cache
itself. The driver compiles the kernels before it starts the pool, so this only loads them.

Ctrl-C is ignored from the start: the forkserver process imports this module before it sets
its own handlers, and an interrupt there would only print a traceback (the driver stops the
pool).
"""
import signal

signal.signal(signal.SIGINT, signal.SIG_IGN)

import numpy as np  # noqa: E402

from . import steps  # noqa: F401,E402  (the tasks the workers run)
from ..controllers import OpenLoop  # noqa: E402
from ..simulation import evaluate_gaits, initial_state, run_controller  # noqa: E402

evaluate_gaits(np.array([[1.0, 11.0]]))
run_controller(OpenLoop(0.01, 0.01, 0.6354), initial_state(1.0, 11.0), t_end=0.05,
               sample_dt=0.01)
