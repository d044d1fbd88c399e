"""Forkserver preload: import the task functions *and* load their compiled kernels once.

Numba loads a cached function on its first call, in each process. The forkserver imports this
module before forking workers, so loading the kernels here (one tiny gait and one short
open-loop run) means every worker starts with them in memory instead of reading the cache
itself.
"""
import numpy as np

from . import steps  # noqa: F401  (the tasks the workers run)
from ..controllers import OpenLoop
from ..simulate import evaluate_gaits, initial_state, run_controller

evaluate_gaits(np.array([[1.0, 11.0]]))
run_controller(OpenLoop(0.01, 0.01, 0.6354), initial_state(1.0, 11.0), t_end=0.05,
               sample_dt=0.01)
