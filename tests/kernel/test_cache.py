"""The kernels' on-disk cache never outlives its sources: an edit of a callee of the hybrid loop
(in a copy of the package, with a persistent cache, as a user's clone or an upgraded install
has) reaches the cached loop, and nothing is cached beside the sources."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import monkeystudy
from monkeystudy.kernel import jit

PKG = Path(monkeystudy.__file__).resolve().parent

# one swing of the horizontal gait's start through the hybrid loop (simulate: the loop of
# DOP853 without flight, cached under its own name), printed to the last bit
SWING = """
import numpy as np
from monkeystudy import OpenLoop, run_controller
from monkeystudy.simulation import initial_state
r = run_controller(OpenLoop(0.43, 0.024, 0.6354), initial_state(0.9, 10.93), cycles=1)
print(np.asarray(r.state, float).tobytes().hex(), int(r.steps))
"""


def _swing(copy: Path, cache: Path) -> str:
    env = {**os.environ, "PYTHONPATH": str(copy), "NUMBA_CACHE_DIR": str(cache),
           "PYTHONDONTWRITEBYTECODE": "1"}
    res = subprocess.run([sys.executable, "-c", SWING], env=env, capture_output=True,
                         text=True, timeout=1800, cwd=copy)
    assert res.returncode == 0, res.stderr
    return res.stdout.strip()


def _set_safety(copy: Path, value: str) -> None:
    path = copy / "monkeystudy" / "kernel" / "integrate.py"
    text = path.read_text()
    old = next(line for line in text.splitlines() if line.startswith("SAFETY = "))
    path.write_text(text.replace(old, f"SAFETY = {value}", 1))


@pytest.mark.slow
def test_an_edit_of_a_callee_of_the_cached_loop_reaches_it(tmp_path):
    copy, cache = tmp_path / "pkg", tmp_path / "cache"
    shutil.copytree(PKG, copy / "monkeystudy", ignore=shutil.ignore_patterns("__pycache__"))
    kernel = copy / "monkeystudy" / "kernel"
    before = _swing(copy, cache)

    _set_safety(copy, "0.8")          # the step-size controller's safety factor: other steps
    edited = _swing(copy, cache)
    assert edited != before, "the cached loop ran the integrator as it was before the edit"
    edited_digest = jit.kernel_sources_digest(kernel)

    _set_safety(copy, "0.9")          # the sources as they were: their cache is still there
    assert _swing(copy, cache) == before
    assert sorted(p.name for p in cache.iterdir()) == sorted(
        "kernel-" + digest[:16] for digest in (jit.kernel_sources_digest(kernel), edited_digest))
    beside = [str(p) for p in copy.rglob("*") if p.suffix in (".nbi", ".nbc")]
    assert not beside, beside


def test_a_kernel_is_cached_in_the_folder_of_every_kernel_source_and_nowhere_else():
    """Every kernel, those made after import included (the hybrid loops, the specialised
    copies), is cached by the kernels' locator, stamped with the hash of every source."""
    from monkeystudy.kernel import hybrid, integrate
    from monkeystudy.kernel.layout import FLIES  # noqa: F401  (the constant copies set)
    loop = hybrid.hybrid_loop(integrate.METHOD_DOP853, flies=False)
    kernels = [integrate.rhs, loop, *[d for d, _ in hybrid.loop_callees(integrate.METHOD_DOP853)]]
    for kernel in kernels:
        locator = kernel._cache._impl.locator
        assert isinstance(locator, jit.KernelCacheLocator), kernel
        assert locator.get_cache_path() == jit.KERNEL_CACHE_DIR
        assert locator.get_source_stamp() == jit.KERNEL_DIGEST


def test_the_digest_changes_with_any_kernel_source(tmp_path):
    folder = tmp_path / "kernel"
    shutil.copytree(jit.KERNEL_SOURCE_DIR, folder, ignore=shutil.ignore_patterns("__pycache__"))
    assert jit.kernel_sources_digest(folder) == jit.KERNEL_DIGEST
    roots = folder / "roots.py"
    roots.write_text(roots.read_text() + "\n")
    assert jit.kernel_sources_digest(folder) != jit.KERNEL_DIGEST


def test_a_function_outside_the_kernel_is_cached_nowhere():
    """``njit(cache=True)`` on a function whose source is not a kernel module (no hash covers
    its source) compiles it in each process: no cache files beside it, none stale."""
    @jit.njit(cache=True)
    def twice(x):
        return 2.0 * x

    assert twice(1.5) == 3.0
    assert type(twice._cache).__name__ == "NullCache"
    assert not list(Path(__file__).parent.glob("__pycache__/*test_cache*.nb[ic]"))
