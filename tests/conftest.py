"""Shared pytest configuration.

``tests/`` is put on ``sys.path`` so that test modules can import the independent reference
model as ``reference`` (``tests/reference/``), whatever pytest's import mode.

The suite runs on every core (pytest-xdist, ``-n auto`` in ``pyproject.toml``). Each worker
compiles into a kernel cache of its own: numba rewrites a function's whole cache index on each
save, so two processes compiling different signatures of one function into one cache at once
could lose or misfile one of them. The variable is set before anything imports the kernels,
and the runs the tests start as subprocesses inherit it.
"""
import os
import pathlib
import signal
import sys

_TESTS = pathlib.Path(__file__).resolve().parent
if str(_TESTS) not in sys.path:
    sys.path.insert(0, str(_TESTS))

_WORKER = os.environ.get("PYTEST_XDIST_WORKER")
if _WORKER:
    _BASE = os.environ.get("NUMBA_CACHE_DIR") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(pathlib.Path.home(), ".cache"),
        "monkeystudy")
    os.environ["NUMBA_CACHE_DIR"] = os.path.join(_BASE, f"tests-{_WORKER}")

# A suite started in the background of a shell without job control inherits SIGINT ignored
# (POSIX), and so would every run a test starts: no Ctrl-C the tests send would reach them,
# and those tests would wait out their hang guards. The tests send SIGINT as a terminal's
# Ctrl-C does, to processes that take it.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
