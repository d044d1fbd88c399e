"""Compiling ahead (monkeystudy.compiling): the helper's list is the hybrid loop's own callees,
and two processes compiling into one empty cache at once leave a cache that serves a third
with the same results."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from monkeystudy import compiling
from monkeystudy.simulate import evaluate_gaits

POINTS = [[1.0, 11.0], [0.9, 10.9], [1.3, 10.5], [0.2, 12.5]]

# in a fresh process: the callees compiled first (as the helper does), then a first gait, with
# numba's compile events recorded for both
CALLEES_THEN_GAIT = """
import json, numpy as np
from numba.core import event as ev
from monkeystudy.compiling import compile_callees
from monkeystudy.kernel.hybrid import loop_callees
from monkeystudy.simulate import evaluate_gaits
def compiled(rec):
    return {e.data["dispatcher"] for _, e in rec.buffer
            if e.is_start and hasattr(e.data.get("dispatcher"), "signatures")}
with ev.install_recorder("numba:compile") as ahead:
    compile_callees("dop853")
with ev.install_recorder("numba:compile") as gait:
    r = evaluate_gaits(np.array(%r))
listed = {d for d, _ in loop_callees(1)}
print(json.dumps({
    "error": r["error"].tobytes().hex(), "t_end": r["t_end"].tobytes().hex(),
    "ahead": len(compiled(ahead)),
    "listed_compiled_again": sorted(d.py_func.__qualname__ for d in compiled(gait) & listed),
    "several_signatures": sorted(d.py_func.__qualname__ for d in compiled(ahead)
                                 if len(d.signatures) != 1),
}))
"""

# the gaits at POINTS, and how many functions this process compiled
GAITS = """
import json, numpy as np
from numba.core import event as ev
from monkeystudy.simulate import evaluate_gaits
with ev.install_recorder("numba:compile") as rec:
    r = evaluate_gaits(np.array(%r))
print(json.dumps({"compiled": sum(1 for _, e in rec.buffer if e.is_start),
                  "error": r["error"].tobytes().hex(), "t_end": r["t_end"].tobytes().hex(),
                  "status": r["status"].tolist()}))
"""


def _python(code: str, cache, timeout=900) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache))
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=timeout, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_the_callees_are_those_the_loop_compiles(tmp_path):
    # after the helper's list, a first gait compiles none of those again (the argument types
    # are the loop's), and each function the list compiled has one signature (two processes
    # saving different signatures of one function at once could misfile them); compiled in
    # that order (numba compiles a callee with its first caller's flags), the same bits
    r = _python(CALLEES_THEN_GAIT % POINTS, tmp_path)
    assert r["ahead"] > 20, r
    assert r["listed_compiled_again"] == [], r
    assert r["several_signatures"] == [], r
    here = evaluate_gaits(np.array(POINTS))
    assert r["error"] == here["error"].tobytes().hex()
    assert r["t_end"] == here["t_end"].tobytes().hex()


@pytest.mark.slow
def test_two_processes_compile_into_one_cache(tmp_path, monkeypatch):
    """A first run's two processes (the helper and the driver's first gait) compile into one
    empty cache: no temporary file is left, a third process compiles nothing and computes
    the same bits, and the cache holds DOP853's swing step but no other method's steps and no
    flight step (the method and the phase set are compile-time choices)."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    helper = compiling.start("dop853")     # compiles the callees, last first ...
    try:
        driver = _python(GAITS % POINTS, tmp_path)   # ... while this compiles the gait
    finally:
        helper.wait(timeout=900)           # not stopped: both run to the end
    assert helper.returncode == 0
    assert driver["compiled"] > 0
    assert not [p for p in tmp_path.rglob("*") if ".tmp." in p.name]
    cached = {p.name for p in tmp_path.rglob("*.nbi")}
    assert any(n.startswith("rk_explicit.dop853_step4-") for n in cached), sorted(cached)
    assert not any(n.startswith(("rk_explicit.vern9_", "rk_explicit.rk45_",
                                 "rk_explicit.dop853_step8-", "rk_explicit.dop853_dense8-"))
                   for n in cached), sorted(n for n in cached if n.startswith("rk_explicit."))
    # a third process compiles nothing and computes the same bits as this one
    third = _python(GAITS % POINTS, tmp_path)
    assert third["compiled"] == 0, third
    here = evaluate_gaits(np.array(POINTS))
    for r in (driver, third):
        assert r["status"] == here["status"].tolist()
        assert r["error"] == here["error"].tobytes().hex()
        assert r["t_end"] == here["t_end"].tobytes().hex()


def test_stop_ends_a_running_helper():
    helper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    compiling.stop(helper)
    assert helper.returncode is not None
    compiling.stop(None)   # no helper (it could not start): nothing to do


def test_call_with_frame_room_returns_and_raises_like_a_call():
    assert compiling.call_with_frame_room(lambda: 42) == 42
    with pytest.raises(ZeroDivisionError):
        compiling.call_with_frame_room(lambda: 1 / 0)
