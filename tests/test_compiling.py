"""Compiling ahead (monkeystudy.compiling): the helper's list is the hybrid loop's own callees,
two processes compiling into one empty cache at once leave a cache that serves a third with
the same results, and the loop is compiled once for every entry and process that needs it."""
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from monkeystudy import OpenLoop, compiling, initial_state, run_controller
from monkeystudy.simulation import evaluate_gaits

POINTS = [[1.0, 11.0], [0.9, 10.9], [1.3, 10.5], [0.2, 12.5]]

# in a fresh process: the callees compiled first (as the helper does), then a first gait, with
# numba's compile events recorded for both
CALLEES_THEN_GAIT = """
import json, numpy as np
from numba.core import event as ev
from monkeystudy.compiling import compile_callees
from monkeystudy.kernel.hybrid import loop_callees
from monkeystudy.simulation import evaluate_gaits
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

# the gaits at POINTS and a short open-loop run (a study's two entries of the loop), and how
# many functions this process compiled
GAITS = """
import json, numpy as np
from numba.core import event as ev
from monkeystudy import OpenLoop, initial_state, run_controller
from monkeystudy.simulation import evaluate_gaits
with ev.install_recorder("numba:compile") as rec:
    r = evaluate_gaits(np.array(%r))
    run = run_controller(OpenLoop(0.43, 0.024, 0.6354, tick=0.001), initial_state(0.9, 10.93),
                         cycles=2, sample_dt=0.01)
print(json.dumps({"compiled": sum(1 for _, e in rec.buffer if e.is_start),
                  "error": r["error"].tobytes().hex(), "t_end": r["t_end"].tobytes().hex(),
                  "status": r["status"].tolist(), "run": run.sample_state.tobytes().hex()}))
"""


# a study's warm-up on an empty cache (a first run: the helper runs beside it): how often this
# process compiled each function
WARM_UP = """
import collections, json
from numba.core import event as ev
from monkeystudy.study.loader import load_study
from monkeystudy.study.runner import load_kernels
from monkeystudy.study.spec import gait_spec
spec = gait_spec(load_study(%r).study)
with ev.install_recorder("numba:compile") as rec:
    load_kernels(spec, runs=True, ahead=True)
print(json.dumps(collections.Counter(e.data["dispatcher"].py_func.__qualname__
                                     for _, e in rec.buffer if e.is_start)))
""" % str(Path(__file__).resolve().parents[1] / "studies" / "smoke.yaml")

# another entry of the loop in a later process: an open-loop run and the names it compiled
LATER_RUN = """
import json
from numba.core import event as ev
from monkeystudy import OpenLoop, initial_state, run_controller
with ev.install_recorder("numba:compile") as rec:
    run = run_controller(OpenLoop(0.43, 0.024, 0.6354, tick=0.001), initial_state(0.9, 10.93),
                         cycles=2, sample_dt=0.01)
print(json.dumps({"compiled": sorted({e.data["dispatcher"].py_func.__qualname__
                                      for _, e in rec.buffer if e.is_start}),
                  "run": run.sample_state.tobytes().hex()}))
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
    # compiles the callees, last first ...
    helper = compiling.start("dop853")
    try:
        driver = _python(GAITS % POINTS, tmp_path)   # ... while this compiles both entries
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
    run = run_controller(OpenLoop(0.43, 0.024, 0.6354, tick=0.001), initial_state(0.9, 10.93),
                         cycles=2, sample_dt=0.01)
    for r in (driver, third):
        assert r["status"] == here["status"].tolist()
        assert r["error"] == here["error"].tobytes().hex()
        assert r["t_end"] == here["t_end"].tobytes().hex()
        assert r["run"] == run.sample_state.tobytes().hex()


@pytest.mark.slow
def test_the_loop_is_compiled_once_for_every_entry_and_process(tmp_path, monkeypatch):
    """A first run's warm-up with multi-cycle runs compiles the hybrid loop once, which the
    gait evaluation (a batch of the loop) and the runs both call, with no compiled caller of
    its own to link it again; a later process's run loads it from the cache (the loop is
    most of a first run's compile) and computes the same bits."""
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    compiled = _python(WARM_UP, tmp_path)
    loops = {name: n for name, n in compiled.items() if name.startswith("hybrid_loop_")}
    assert loops == {"hybrid_loop_dop853_swing": 1}, compiled
    assert "cycle_gait_batch" not in compiled, compiled
    later = _python(LATER_RUN, tmp_path)
    assert not [n for n in later["compiled"] if n.startswith("hybrid_loop_")], later
    run = run_controller(OpenLoop(0.43, 0.024, 0.6354, tick=0.001), initial_state(0.9, 10.93),
                         cycles=2, sample_dt=0.01)
    assert later["run"] == run.sample_state.tobytes().hex()


def test_stop_ends_a_running_helper():
    helper = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    compiling.stop(helper)
    assert helper.returncode is not None
    compiling.stop(None)   # no helper (it could not start): nothing to do


def test_call_with_frame_room_returns_and_raises_like_a_call():
    assert compiling.call_with_frame_room(lambda: 42) == 42
    with pytest.raises(ZeroDivisionError):
        compiling.call_with_frame_room(lambda: 1 / 0)
