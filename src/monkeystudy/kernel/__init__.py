"""Compiled kernels: pure ``@njit(cache=True)`` functions on float64 arrays.

Never imports xarray, yaml, matplotlib or the study layer (a test enforces it).

Every kernel function is compiled with numpy's error model (``error_model="numpy"``): a
division by zero gives ``inf`` or ``nan`` (which the hybrid loop reports as ``ST_NONFINITE``),
never an exception. Functions that allocate nothing are also compiled without numba's runtime
(``_nrt=False``): numba otherwise increfs each array argument on entry and decrefs it on exit
(atomic operations) wherever its pruning pass cannot prove the pair redundant, which it cannot
in a function that calls another that calls a third (what that cost a gait:
docs/performance.md, "What makes a gait cheap"). Such a function fails to compile if it ever
creates an array, rather than running wrongly.

Small functions are inlined by LLVM (``forceinline=True``): compiled once, then inlined into
each caller's machine code. Numba's own inlining (``inline="always"``) gives the same code but
copies and re-analyses the function's IR at every call site, which makes a first run's compile
seconds longer (docs/performance.md, "Compiling"). Numba's inlining is kept
where the inlined code must take its caller's flags (the vector field in the Runge-Kutta
steps, compiled with floating-point contraction: ``dynamics.swing_accel_fused`` and its kin),
for the wrappers that would otherwise add a level of compiled code above the hybrid loop
(``gait.simulate_unlogged``), and for the reduced sine and cosine of ``trig`` (inlined by LLVM
instead, some results changed in their last bits; not yet explained, so not done).

Numba compiles a function that a caller reaches while being typed with that caller's
floating-point and runtime flags: the first caller decides (a function with ``_nrt=False``
cannot reach one that allocates; a plain function first reached from a ``fastmath`` caller is
compiled with fast-math). So no kernel function is reached from callers with different flags:
the Runge-Kutta steps call only their ``*_fused`` fields and overloads (compiled per caller),
and ``tests/test_compiling.py`` checks that compiling the hybrid loop's callees first, as
the compile-ahead helper does, gives the same bits.

Numba's on-disk cache checks only the source file of each function, not of the functions it
calls: edit ``integrate.py`` and a cached hybrid loop (``hybrid.hybrid_loop``) keeps running
the old integrator.
So the cache lives in a directory keyed by a hash of *all* kernel sources (below
``$NUMBA_CACHE_DIR`` if set, else the user cache directory): any kernel change compiles afresh,
and an unchanged kernel loads from disk in well under a second.
"""
import hashlib
import os
from pathlib import Path

from numba.core import config as _numba_config


def _kernel_cache_dir() -> str:
    here = Path(__file__).resolve().parent
    digest = hashlib.sha256()
    for src in sorted(here.glob("*.py")):
        digest.update(src.name.encode())
        digest.update(src.read_bytes())
    base = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(Path.home(), ".cache"), "monkeystudy")
    return os.path.join(base, "kernel-" + digest.hexdigest()[:16])


KERNEL_CACHE_DIR = _kernel_cache_dir()
_saved_cache_dir = _numba_config.CACHE_DIR
try:
    os.makedirs(KERNEL_CACHE_DIR, exist_ok=True)
    _numba_config.CACHE_DIR = KERNEL_CACHE_DIR
except OSError:  # read-only home: fall back to numba's own choice (in-tree __pycache__)
    KERNEL_CACHE_DIR = ""
try:
    # every kernel module is decorated now, while the cache directory is ours; then the
    # global setting goes back to what it was, so other numba users are unaffected
    from . import (  # noqa: F401
        design, dynamics, events, gait, hybrid, integrate, intrinsics, layout, noise,
        rk_explicit, roots, survival, tableaux, trig, variational,
    )
finally:
    _numba_config.CACHE_DIR = _saved_cache_dir
