"""The kernels' compile decorator: numba's ``njit`` without the C-callable wrapper.

Numba compiles, beside every function, a ``cfunc`` wrapper that lets the function be passed as
a first-class function value; no kernel is used that way (they call each other directly), and
the wrappers are about 5 % of a first run's compile (1.0-1.2 s of 21 s of processor time for
the horizontal study's gait evaluation compiled in one process, three runs each way). Every
kernel module compiles through :data:`njit`, with numba's own options otherwise.
"""
from functools import partial

from numba import njit as numba_njit

#: ``numba.njit`` with ``no_cfunc_wrapper=True``; used as ``@njit(cache=True, ...)``
njit = partial(numba_njit, no_cfunc_wrapper=True)

#: the same option for the implementations of ``numba.extending.overload``
OVERLOAD_OPTIONS = {"no_cfunc_wrapper": True}
