"""The kernels' compile decorator, and copies of kernels with some module constants set
otherwise.

:data:`njit` is numba's ``njit`` without the C-callable wrapper. Numba compiles, beside every
function, a ``cfunc`` wrapper that lets the function be passed as a first-class function value;
no kernel is used that way (they call each other directly), and the wrappers are about 5 % of a
first run's compile (1.0-1.2 s of 21 s of processor time for the horizontal study's gait
evaluation compiled in one process, three runs each way). Every kernel module compiles through
:data:`njit`, with numba's own options otherwise.

:func:`specialised` copies a kernel with module constants of its own (e.g. ``FLIES`` False for
runs that never fly): numba reads a module constant as a literal when it compiles, and drops a
branch that a literal condition never takes before typing it, so the copy compiles without the
code that branch calls, and so does every kernel that links the copy.
"""
from functools import partial
from types import CodeType, FunctionType

from numba import jit as numba_jit
from numba import njit as numba_njit
from numba.core.dispatcher import Dispatcher

#: ``numba.njit`` with ``no_cfunc_wrapper=True``; used as ``@njit(cache=True, ...)``
njit = partial(numba_njit, no_cfunc_wrapper=True)

#: the same option for the implementations of ``numba.extending.overload``
OVERLOAD_OPTIONS = {"no_cfunc_wrapper": True}

#: the copies :func:`specialised` has made in this process, by (kernel, suffix, constants)
_COPIES = {}


def _global_names(code: CodeType):
    """The global names ``code`` and the code nested in it read."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, CodeType):
            names |= _global_names(const)
    return names


def specialised_globals(code: CodeType, scope: dict, suffix: str, constants: dict) -> dict:
    """The globals ``code`` (a kernel's, whose globals are ``scope``) compiles with to read
    ``constants`` (module constant name to value) in place of its module's: those names set,
    and each kernel it calls that reads them, itself or through its own calls, replaced by its
    :func:`specialised` copy; ``scope`` itself when nothing ``code`` reads or calls reads
    them."""
    names = _global_names(code)
    changed = {name: value for name, value in constants.items() if name in names}
    for name in names:
        callee = scope.get(name)
        if isinstance(callee, Dispatcher):
            copy = specialised(callee, suffix, **constants)
            if copy is not callee:
                changed[name] = copy
    return dict(scope, **changed) if changed else scope


def specialised(kernel: Dispatcher, suffix: str, **constants) -> Dispatcher:
    """``kernel`` compiled with ``constants`` (module constant name to value) in place of its
    module's, through the kernels it calls: a dispatcher of a copy of its Python function named
    ``<name>_<suffix>`` (its own on-disk cache files), made once per process (two dispatchers
    of one function, both loading its cached compile, would define the same symbols twice).
    ``kernel`` itself when neither it nor any kernel it calls reads those constants.

    The copy keeps ``kernel``'s compile options and is always cached on disk; ``suffix`` must
    name the set of ``constants`` (the cache tells copies apart by their names only).
    """
    key = (kernel, suffix, tuple(sorted(constants.items())))
    if key not in _COPIES:
        function = kernel.py_func
        scope = specialised_globals(function.__code__, function.__globals__, suffix, constants)
        if scope is function.__globals__:
            _COPIES[key] = kernel
        else:
            name = f"{function.__name__}_{suffix}"
            copy = FunctionType(function.__code__, scope, name, function.__defaults__,
                                function.__closure__)
            copy.__qualname__ = name     # numba names its cache files after it
            copy.__doc__ = function.__doc__
            copy.__module__ = function.__module__
            _COPIES[key] = numba_jit(cache=True, locals=kernel.locals,
                                      **kernel.targetoptions)(copy)
    return _COPIES[key]
