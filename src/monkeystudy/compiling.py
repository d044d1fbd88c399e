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
"""
from __future__ import annotations

import subprocess
import sys

from .controllers import METHODS
from .kernel.hybrid import loop_callees


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


if __name__ == "__main__":
    compile_callees(sys.argv[1])
