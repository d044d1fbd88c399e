"""Compiling ahead: a second process compiles the hybrid loop's callees while a first run
compiles the loop.

A study's first run with new kernel code compiles one specialisation of the hybrid loop
(``kernel/hybrid.simulate_implementation``) and, while typing it, every function the loop calls,
one after the other, on one core. :func:`start` launches ``python -m monkeystudy.compiling
METHOD`` on the idle core: it compiles the same callees (``kernel/hybrid.loop_callees``), the
last first, into the same on-disk cache, so the study's process finds the later ones already
saved and loads them. Both processes compile the same signatures of the same functions, each
function with a single signature (numba's cache index holds every signature of a function, and
is rewritten whole on each save; different signatures saved at once by two processes could be
lost or misfiled), and numba writes each file atomically, so the cache ends up the same whichever
process saves a function. :func:`stop` ends the helper once the study's process has what it
needs: whatever the helper was still compiling, the study's process already has.

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
import types
from pathlib import Path

from .controllers import METHODS
from .kernel import KERNEL_CACHE_DIR
from .kernel.hybrid import loop_callees


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


def start(method: str) -> subprocess.Popen | None:
    """Start compiling ahead for ``method`` in a second process (None if it cannot start)."""
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
    code version), else a range measured on two cores."""
    seconds = _read_times().get(what)
    if isinstance(seconds, (int, float)) and seconds > 0:
        return f"about {seconds:.0f} s, as the last first run here took"
    return "15-40 s on two cores"


if __name__ == "__main__":
    call_with_frame_room(lambda: compile_callees(sys.argv[1]))
