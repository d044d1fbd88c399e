"""Compiling ahead: a second process compiles the hybrid loop's callees while a first run
compiles the loop.

A study's first run with new kernel code compiles the hybrid loop of its integration method
(``kernel/hybrid.hybrid_loop``) and, while typing it, every function the loop calls, one after
the other, on one core. :func:`start` launches ``python -m monkeystudy.compiling METHOD`` on
the idle core: it compiles the same callees (``kernel/hybrid.loop_callees``), the last first,
into the same on-disk cache, so the study's process finds the later ones already saved and
loads them. Both processes compile the same signatures of the same functions, each function
with a single signature (numba's cache index holds every signature of a function, and is
rewritten whole on each save; different signatures saved at once by two processes could be
lost or misfiled), and numba writes each file atomically, so the cache ends up the same
whichever process saves a function. :func:`stop` ends the helper once the study's process has
what it needs: whatever the helper was still compiling, the study's process already has. The
loop itself, and every entry that links it (gait evaluations, multi-cycle runs), the study's
process compiles: the loop once, cached under its own name, which every entry links.

Both compile through :func:`call_with_frame_room`: CPython (3.11 and later) keeps its frames in
chunks of 16 KiB and unmaps a chunk as soon as the call depth falls back below it, and numba's
compiler recurses deeply (copies of its IR), so a first gait crossed a chunk's edge some
570 000 times: 1.17 million ``mmap``/``munmap`` calls and 5-8 s of system time (``strace -c``).
Called with room on its frame, a compile runs inside one large chunk and maps none.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import types
from pathlib import Path

import numpy as np

from . import kernel
from .controllers import METHODS
from .kernel.hybrid import loop_callees
from .kernel.layout import PHASE_SWING
from .kernel.variational import (
    energy8_gradient, entry_reset, field8, field8_jacobian, guard8, guard8_gradient,
    holding_torque8, holding_torque8_gradient, variational_rhs8,
)

#: the directory of the kernels' on-disk cache, keyed by a hash of every kernel source
#: (``monkeystudy/kernel/jit.py``); "" when it cannot be written (a read-only home: the
#: kernels then compile in every process, cached nowhere)
KERNEL_CACHE_DIR = kernel.KERNEL_CACHE_DIR


def _call(f):
    return f()


# _call with room for 131 072 values on its frame (1 MiB): CPython gives such a frame a chunk
# of its own of 2 MiB, and the frames it calls fill the other half before needing another
_call_with_room = types.FunctionType(_call.__code__.replace(co_stacksize=131072), globals(),
                                     "_call_with_room")


def call_with_frame_room(f):
    """``f()``, with about 1 MiB of CPython's frame stack free above it (module docstring):
    for compiling, whose deep recursion otherwise maps and unmaps frame-stack chunks."""
    return _call_with_room(f)


def compile_callees(method: str) -> int:
    """Compile (or load from the cache) the hybrid loop's callees for the integration
    ``method`` (a name of :data:`~monkeystudy.controllers.METHODS`), the last the loop reaches
    first; returns how many."""
    callees = loop_callees(METHODS[method][0])
    for dispatcher, argtypes in reversed(callees):
        dispatcher.compile(argtypes)
    return len(callees)


def compile_variational(params: np.ndarray) -> None:
    """Compile (or load from the cache) the variational-equation kernels of floquet and
    continuation steps, with the argument types
    :func:`~monkeystudy.analysis.variational.sequence_variational_jacobian` passes them.

    Parameters
    ----------
    params : numpy.ndarray
        A robot's parameter rows (:meth:`~monkeystudy.robot.Robot.params`), shape ``(2, n)``.
    """
    s = np.array([0.0, 0.0, 0.1, 0.2, 0.0, 0.0, 1.0, 10.0])
    f, grad, A = np.empty(8), np.empty(8), np.empty((8, 8))
    fm = np.ones(2)
    for m in (3, 4):     # section states of 3 (clock reset) and 4 (running clock)
        y = np.concatenate([s, np.eye(8)[:, :m].ravel()])
        variational_rhs8(PHASE_SWING, params[0], 0.0, fm, y, np.empty_like(y))
    field8(PHASE_SWING, params[0], 0.0, fm, s, f)
    field8_jacobian(PHASE_SWING, params[0], 0.0, fm, s, A)
    holding_torque8(PHASE_SWING, params[0], 0.0, fm, s, 1)
    holding_torque8_gradient(PHASE_SWING, params[0], 0.0, fm, s, 1, grad)
    guard8(1, 0, 0.0, params[0], s, 0.0)
    guard8_gradient(1, 0, 0.0, params[0], s, 0.0, grad)
    energy8_gradient(params[0], s, grad)
    entry_reset(params, s, PHASE_SWING, 0, -1.0, -1.0, True, np.empty(8), A)


#: stack of the thread a compile runs on (:func:`on_own_thread`): numba's compiler recurses
#: deeply in C as well; reserved address space, committed only as used
COMPILE_THREAD_STACK = 256 * 2**20


def on_own_thread(f):
    """``f()`` (a compile) run on a thread of its own, with frame room
    (:func:`call_with_frame_room`), while the calling thread waits; returns its result or
    raises its exception.

    A Ctrl-C's ``KeyboardInterrupt`` is raised in the main thread wherever it is: inside
    numba's compiler it can land in a callback from LLVM, where ctypes prints "Exception
    ignored" and drops it (the run then goes on to its end), or leave the compiler half way
    with a traceback of its own. Waiting here, the main thread receives it between two waits
    and raises it at once; the compile, left on its daemon thread, ends with the process
    (numba saves each cache file whole, so nothing half written is taken for cached).
    """
    outcome: dict = {}

    def body():
        try:
            outcome["value"] = call_with_frame_room(f)
        except BaseException as exc:   # handed to the waiting thread
            outcome["error"] = exc

    previous = threading.stack_size(COMPILE_THREAD_STACK)
    try:
        thread = threading.Thread(target=body, name="monkeystudy-compile", daemon=True)
        thread.start()
    finally:
        threading.stack_size(previous)
    while thread.is_alive():
        thread.join(0.05)
    if "error" in outcome:
        raise outcome["error"]
    return outcome.get("value")


def start(method: str) -> subprocess.Popen | None:
    """Start compiling the hybrid loop's callees for ``method`` ahead, in a second process
    (None if it cannot start)."""
    try:
        return subprocess.Popen([sys.executable, "-m", "monkeystudy.compiling", method],
                                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
    except OSError:
        return None


def stop(helper: subprocess.Popen | None) -> None:
    """End a helper from :func:`start`, at once: numba replaces each cache file whole, so an
    interrupted save leaves at most a temporary file or an index entry whose data file is
    missing, which numba takes for "not cached"."""
    if helper is None:
        return
    if helper.poll() is None:
        helper.kill()
    helper.wait()


#: file beside the kernel caches recording how long first compiles took on this machine
COMPILE_TIMES = "compile-times.json"


def _times_path() -> Path | None:
    return Path(KERNEL_CACHE_DIR).parent / COMPILE_TIMES if KERNEL_CACHE_DIR else None


def _read_times() -> dict:
    path = _times_path()
    try:
        data = json.loads(path.read_text()) if path is not None else {}
        return data if isinstance(data, dict) else {}
    except (OSError, ValueError):
        return {}


def record_compile_time(what: str, seconds: float) -> None:
    """Remember that compiling ``what`` (a kernel set, e.g. ``dop853-runs``) took ``seconds``
    here, for the next first run's estimate (written atomically; a read-only cache is fine)."""
    path = _times_path()
    if path is None:
        return
    data = _read_times()
    data[what] = round(float(seconds), 1)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        tmp.write_text(json.dumps(data, sort_keys=True) + "\n")
        os.replace(tmp, path)
    except OSError:
        tmp.unlink(missing_ok=True)


def compile_estimate(what: str) -> str:
    """How long compiling ``what`` should take: the last such compile on this machine (any
    code version, any load), else the range measured on two cores, idle and busy."""
    seconds = _read_times().get(what)
    if isinstance(seconds, (int, float)) and seconds > 0:
        return f"about {seconds:.0f} s, as the last first run here took (longer when busier)"
    return "10-30 s on two idle cores, 1-2 minutes when they are busy"


def _main(argv: list[str]) -> None:
    """``python -m monkeystudy.compiling METHOD`` (:func:`start`)."""
    call_with_frame_room(lambda: compile_callees(argv[0]))
    # every file is saved (numba writes each whole before it returns): skip the interpreter's
    # teardown of what it compiled, about a second after a first compile
    os._exit(0)


if __name__ == "__main__":
    _main(sys.argv[1:])
