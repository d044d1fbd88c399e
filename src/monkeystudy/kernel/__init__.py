"""Compiled kernels: pure ``@njit(cache=True)`` functions on float64 arrays.

Never imports xarray, yaml, matplotlib or the study layer (a test enforces it).

Every kernel function is compiled with numpy's error model (``error_model="numpy"``): a
division by zero gives ``inf`` or ``nan`` (which the hybrid loop reports as ``ST_NONFINITE``),
never an exception. Functions that allocate nothing are also compiled without numba's runtime
(``_nrt=False``): numba otherwise increfs each array argument on entry and decrefs it on exit
(atomic operations) wherever its pruning pass cannot prove the pair redundant, which it cannot
in a function that calls another that calls a third. Such a function fails to compile if it ever
creates an array, rather than running wrongly.

Small functions are inlined by LLVM (``forceinline=True``): compiled once, then inlined into
each caller's machine code. Numba's own inlining (``inline="always"``) gives the same code but
copies and re-analyses the function's IR at every call site, which makes a first run's compile
longer (docs/performance.md, "Compiling"). Numba's inlining is kept
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

Every kernel is cached on disk in a folder keyed by a hash of *all* kernel sources and the
compiling libraries' versions (``jit.KERNEL_CACHE_DIR``, below ``$NUMBA_CACHE_DIR`` if set,
else the user cache directory), whenever it is made: numba's own cache checks only each
function's own file, so an edit of ``integrate.py`` would otherwise leave a cached hybrid loop
(``hybrid.hybrid_loop``) running the old integrator. Any kernel change or upgrade compiles
afresh, and an unchanged kernel loads from disk in well under a second.
"""
from .jit import KERNEL_CACHE_DIR, KERNEL_DIGEST  # noqa: F401
from . import (  # noqa: F401,E402
    design, dynamics, events, gait, hybrid, integrate, intrinsics, layout, noise, rk_explicit,
    roots, survival, tableaux, trig, variational,
)
