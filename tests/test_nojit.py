"""Run the kernel tests once with numba's JIT disabled (``NUMBA_DISABLE_JIT=1``).

Coverage tools cannot see compiled code, and numba's typed semantics can differ from Python's
(integer division, overflow, in-place aliasing): so the kernel's physics tests also run
interpreted. The variable must be set before Python starts (numba reads it once, at import),
hence a subprocess.

Selected with the ``nojit`` marker (``pyproject.toml``): every test of ``test_dynamics``,
``test_impact``, ``test_tableaux``, ``test_integrate``, ``test_events`` and ``test_friction``,
and in ``test_hybrid_vs_scipy`` the study point, the folded-swap fixtures, the ticked gaits, the
guard checks, the mirror symmetry, the energy floor and the unreachable points.

Excluded, because they repeat code paths covered above at length (interpreted, each takes 1-2 s
where compiled it takes milliseconds; together they would double this run):

* ``test_conservation`` (100 s runs at rtol 1e-12);
* ``test_hybrid_vs_scipy``'s ``slow`` sweeps: the 21-point gait comparison and the grazing
  points (which also search for the grazing starts with the reference model).
"""
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _env():
    env = dict(os.environ)
    env["NUMBA_DISABLE_JIT"] = "1"
    return env


def test_kernel_is_interpreted_when_jit_disabled():
    """The switch really works: kernel functions are plain Python functions."""
    code = ("from monkeystudy.kernel import dynamics, hybrid\n"
            "import types\n"
            "assert isinstance(dynamics.rhs_swing, types.FunctionType)\n"
            "assert isinstance(hybrid.simulate, types.FunctionType)\n")
    r = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=_env(),
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr


@pytest.mark.slow
def test_kernel_tests_pass_without_jit():
    r = subprocess.run([sys.executable, "-m", "pytest", "tests/kernel", "-m", "nojit", "-q",
                        "-p", "no:cacheprovider", "-o", "addopts="],
                       cwd=ROOT, env=_env(), capture_output=True, text=True, timeout=1200)
    tail = r.stdout[-3000:] + r.stderr[-2000:]
    assert r.returncode == 0, tail
    assert " passed" in r.stdout and " failed" not in r.stdout, tail
    assert "skipped" not in r.stdout, tail
