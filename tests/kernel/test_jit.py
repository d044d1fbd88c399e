"""Copies of kernels with module constants of their own (kernel/jit.specialised)."""
import numpy as np

from monkeystudy.kernel.jit import njit, specialised

SCALE = 2.0


@njit(cache=True)
def scaled(x):
    return SCALE * x


@njit(cache=True)
def scaled_twice(x):
    return scaled(scaled(x))


@njit(cache=True)
def unscaled(x):
    return x + 1.0


@njit(cache=True)
def branching(x):
    if SCALE > 1.0:
        return np.sqrt(x)     # a branch the copy never types: it would fail on a string
    return 0.0


def test_a_copy_reads_its_constants_itself_and_through_its_callees():
    half = specialised(scaled_twice, "half", SCALE=0.5)
    assert half(8.0) == 2.0
    assert scaled_twice(8.0) == 32.0          # the original keeps the module's constant
    assert half.py_func.__name__ == "scaled_twice_half"
    assert half.py_func.__globals__["scaled"] is specialised(scaled, "half", SCALE=0.5)
    assert specialised(scaled_twice, "half", SCALE=0.5) is half    # one per process


def test_a_kernel_that_reads_none_of_the_constants_is_itself():
    assert specialised(unscaled, "half", SCALE=0.5) is unscaled


def test_a_branch_on_a_constant_is_dropped_before_typing():
    # the copy never takes the sqrt branch, so numba does not type it: a string argument,
    # which np.sqrt cannot take, compiles and returns the other branch's value
    never = specialised(branching, "small", SCALE=0.5)
    assert never("not a number") == 0.0
    assert branching(4.0) == 2.0
