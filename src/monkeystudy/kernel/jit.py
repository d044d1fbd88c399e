"""The kernels' compile decorator, their on-disk cache, and copies of kernels with some module
constants set otherwise.

:func:`njit` is numba's ``njit`` without the C-callable wrapper, cached where every kernel
source decides. Numba compiles, beside every function, a ``cfunc`` wrapper that lets the
function be passed as a first-class function value; no kernel is used that way (they call each
other directly), and compiling the wrappers would lengthen every first run. Every kernel module compiles through :func:`njit`, with numba's own options
otherwise.

**The cache.** Numba's own cache checks only the source file of each function (its modification
time and size), not the files of the functions it calls, and its folder is chosen when the
function is decorated (``NUMBA_CACHE_DIR`` or beside the source). A cached hybrid loop
(``hybrid.hybrid_loop``) would keep running the integrator of ``integrate.py`` as it was when
the loop was compiled. So every kernel, whenever it is made (at import, or later: the hybrid
loops, the :func:`specialised` copies), is cached by :class:`KernelCacheLocator` alone: in
:data:`KERNEL_CACHE_DIR`, a folder named by a hash of every kernel source and of the versions
of Python, numpy, numba and llvmlite, with that hash as each index's stamp. Any kernel change,
or an upgrade, compiles afresh; an unchanged kernel loads from disk. Nothing is cached beside
the sources; where the folder cannot be written, kernels compile in each process (with a
warning) rather than risk a stale cache.

:func:`specialised` copies a kernel with module constants of its own (e.g. ``FLIES`` False for
runs that never fly): numba reads a module constant as a literal when it compiles, and drops a
branch that a literal condition never takes before typing it, so the copy compiles without the
code that branch calls, and so does every kernel that links the copy. The same mechanism sets
kernels in place of others: a :class:`Model` is the named set of kernels that make the robot's
model (``kernel/dynamics.py``, the room), and the hybrid loop of a model other than the
two-link one calls that model's kernels through copies of its callees.
"""
import hashlib
import os
import platform
import sys
import warnings
from pathlib import Path
from types import CodeType, FunctionType

import llvmlite
import numba
import numpy
from numba import jit as numba_jit
from numba.core.caching import CompileResultCacheImpl, FunctionCache, _CacheLocator
from numba.core.dispatcher import Dispatcher

#: the kernel package's folder: every ``*.py`` in it is a kernel source
KERNEL_SOURCE_DIR = Path(__file__).resolve().parent


def kernel_sources_digest(folder: Path = KERNEL_SOURCE_DIR) -> str:
    """SHA-256 (hex) of every kernel source in ``folder`` (names and bytes, sorted by name)
    and of the versions of Python, numpy, numba and llvmlite that compile them."""
    digest = hashlib.sha256()
    for src in sorted(folder.glob("*.py")):
        digest.update(src.name.encode() + b"\0")
        digest.update(src.read_bytes() + b"\0")
    for version in (platform.python_implementation(), sys.version, numpy.__version__,
                    numba.__version__, llvmlite.__version__):
        digest.update(version.encode() + b"\0")
    return digest.hexdigest()


#: the hash of every kernel source and the compiling libraries' versions (hex)
KERNEL_DIGEST = kernel_sources_digest()


def kernel_cache_dir(digest: str = KERNEL_DIGEST) -> str:
    """The kernels' cache folder: ``kernel-<digest[:16]>`` below ``$NUMBA_CACHE_DIR`` if set,
    else below ``$XDG_CACHE_HOME/monkeystudy`` (``~/.cache/monkeystudy``)."""
    base = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(Path.home(), ".cache"), "monkeystudy")
    return os.path.join(base, "kernel-" + digest[:16])


def _writable_cache_dir(path: str) -> str:
    """``path``, created, if this process can write files in it; else ``""``."""
    try:
        os.makedirs(path, exist_ok=True)
        probe = os.path.join(path, f".probe-{os.getpid()}")
        with open(probe, "wb"):
            pass
        os.remove(probe)
    except OSError:
        return ""
    return path


#: the folder every kernel is cached in; "" when it cannot be written (kernels then compile
#: in each process, and are cached nowhere)
KERNEL_CACHE_DIR = _writable_cache_dir(kernel_cache_dir())


class KernelCacheLocator(_CacheLocator):
    """Numba cache locator of the kernels: :data:`KERNEL_CACHE_DIR`, stamped with
    :data:`KERNEL_DIGEST`, for functions whose source is a kernel module; none for others."""

    def __init__(self, py_func, py_file):
        self._py_file = py_file
        self._lineno = py_func.__code__.co_firstlineno

    def get_cache_path(self):
        return KERNEL_CACHE_DIR

    def get_source_stamp(self):
        # every kernel source, not this function's file alone: a callee's edit must be seen
        return KERNEL_DIGEST

    def get_disambiguator(self):
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func, py_file):
        if not KERNEL_CACHE_DIR or Path(py_file).resolve().parent != KERNEL_SOURCE_DIR:
            return None
        return cls(py_func, py_file)


class KernelCacheImpl(CompileResultCacheImpl):
    """Numba's compile-result cache, located by :class:`KernelCacheLocator` only."""

    _locator_classes = [KernelCacheLocator]


class KernelFunctionCache(FunctionCache):
    """Numba's function cache, located by :class:`KernelCacheLocator` only."""

    _impl_class = KernelCacheImpl


_WARNED_UNCACHED = []


def cache_in_kernel_dir(dispatcher: Dispatcher) -> Dispatcher:
    """Give ``dispatcher`` the kernels' on-disk cache if its function's source is a kernel
    module (a function defined elsewhere, e.g. in a test, is compiled in each process: its
    source is not in :data:`KERNEL_DIGEST`, so no cache could tell when it is stale);
    returns it. With ``NUMBA_DISABLE_JIT`` set, numba returns the Python function itself:
    nothing to cache."""
    if not isinstance(dispatcher, Dispatcher):
        return dispatcher
    if KernelCacheLocator.from_function(dispatcher.py_func,
                                        dispatcher.py_func.__code__.co_filename) is None:
        if not KERNEL_CACHE_DIR and not _WARNED_UNCACHED:
            _WARNED_UNCACHED.append(True)
            warnings.warn(f"cannot write the kernel cache {kernel_cache_dir()!r}: kernels "
                          "are compiled in every process (set NUMBA_CACHE_DIR to a writable "
                          "folder)", RuntimeWarning, stacklevel=3)
        return dispatcher
    # numba's dispatcher holds its cache as ``_cache`` (``Dispatcher.enable_caching`` sets a
    # ``FunctionCache`` there, located by numba's own locators)
    dispatcher._cache = KernelFunctionCache(dispatcher.py_func)
    return dispatcher


def njit(function=None, *, cache: bool = False, **options):
    """``numba.njit(**options)`` without the C-callable wrapper; with ``cache=True`` cached
    in :data:`KERNEL_CACHE_DIR` (module docstring). Used as ``@njit(cache=True, ...)`` or
    ``njit(cache=True, ...)(function)``; ``cache=True`` on a function that is not in a kernel
    module compiles it in each process, cached nowhere."""
    options = dict(options, nopython=True, no_cfunc_wrapper=True)

    def decorate(f):
        dispatcher = numba_jit(**options)(f)
        return cache_in_kernel_dir(dispatcher) if cache else dispatcher
    return decorate if function is None else decorate(function)


#: the same option for the implementations of ``numba.extending.overload``
OVERLOAD_OPTIONS = {"no_cfunc_wrapper": True}


#: the copies :func:`specialised` and :func:`renamed` have made in this process, by (kernel,
#: suffix, constants)
_COPIES = {}
#: a global absent from a kernel's scope (None could be a module constant's value)
_UNSET = object()


def _global_names(code: CodeType):
    """The global names ``code`` and the code nested in it read."""
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, CodeType):
            names |= _global_names(const)
    return names


def specialised_globals(code: CodeType, scope: dict, suffix: str, constants: dict) -> dict:
    """The globals ``code`` (a kernel's, whose globals are ``scope``) compiles with to read
    ``constants`` (global name to value: a module constant, or a kernel in place of the one of
    that name, as a :class:`Model` gives them) in place of its module's: those names set, and
    each kernel it calls that reads them, itself or through its own calls, replaced by its
    :func:`specialised` copy; ``scope`` itself when nothing ``code`` reads or calls reads
    them, or reads them as they are (the very objects ``constants`` gives)."""
    names = _global_names(code)
    changed = {name: value for name, value in constants.items()
               if name in names and scope.get(name, _UNSET) is not value}
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
        _COPIES[key] = kernel if scope is function.__globals__ else \
            _compiled_copy(kernel, suffix, scope)
    return _COPIES[key]


def _compiled_copy(kernel: Dispatcher, suffix: str, scope: dict) -> Dispatcher:
    """A dispatcher of ``kernel``'s Python function with the globals ``scope``, named
    ``<name>_<suffix>``, with ``kernel``'s compile options, cached on disk."""
    function = kernel.py_func
    name = f"{function.__name__}_{suffix}"
    copy = FunctionType(function.__code__, scope, name, function.__defaults__,
                        function.__closure__)
    copy.__qualname__ = name     # numba names its cache files after it
    copy.__doc__ = function.__doc__
    copy.__module__ = function.__module__
    return njit(cache=True, locals=kernel.locals, **kernel.targetoptions)(copy)


def renamed(kernel: Dispatcher, suffix: str) -> Dispatcher:
    """``kernel`` as a kernel of its own, ``<name>_<suffix>``: the same code, globals and
    compile options, compiled and cached apart (made once per process, as
    :func:`specialised` copies are). For a :class:`Model` made of another's kernels."""
    key = (kernel, suffix, "renamed")
    if key not in _COPIES:
        _COPIES[key] = _compiled_copy(kernel, suffix, kernel.py_func.__globals__)
    return _COPIES[key]


class Model:
    """A model of the robot for the hybrid loop: a name and the kernels that make it, by the
    global names the loop and its callees call them (``kernel/dynamics.MODEL_KERNELS``).

    :func:`monkeystudy.kernel.hybrid.hybrid_loop` builds a loop of a model as it builds one of
    an integration method: a copy of the loop whose globals, and those of every callee that
    reads one of these names (:func:`specialised_globals`, suffix :attr:`name`), are the
    model's kernels. Hashable by name and kernels.
    """

    def __init__(self, name: str, kernels: dict):
        if not name.isidentifier():
            raise ValueError(f"a model's name must be an identifier, got {name!r}")
        self.name = name
        #: global name to kernel (numba dispatchers)
        self.kernels = dict(kernels)
        self._key = (name, tuple(sorted(self.kernels.items())))

    def __eq__(self, other):
        return isinstance(other, Model) and self._key == other._key

    def __hash__(self):
        return hash(self._key)

    def __repr__(self):
        return f"Model({self.name!r}, {len(self.kernels)} kernels)"
