"""The runner: identical datasets for 1 or 2 workers, local or Dask, clean or resumed after a
kill; unchanged studies do no work; stale shards are never reused; files appear atomically."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from monkeystudy.study import load_study, plan_study, run_study
from monkeystudy.study import blocks as B
from monkeystudy.study import datasets as D
from monkeystudy.study import runner as R
from monkeystudy.study.errors import RunFailed, RunInterrupted
from monkeystudy.study.pool import Pool
from monkeystudy.study.steps import grid

from studyhelpers import TINY, TINY_FILES, assert_same_datasets, write_study


def test_one_worker_equals_two(tiny_reference, tmp_path):
    study, ref = tiny_reference
    run_study(load_study(study), tmp_path / "one", workers=1)
    assert_same_datasets(ref, tmp_path / "one", TINY_FILES)


def test_dask_cluster_equals_local(tiny_reference, tmp_path):
    distributed = pytest.importorskip("distributed")
    study, ref = tiny_reference
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  host="127.0.0.1", dashboard_address=None) as cluster:
        summary = run_study(load_study(study), tmp_path / "dask",
                            scheduler=cluster.scheduler_address)
    assert len(summary.written) == len(TINY_FILES)
    assert_same_datasets(ref, tmp_path / "dask", TINY_FILES)


def test_datasets_follow_the_contract(tiny_reference):
    study, ref = tiny_reference
    text = study.read_text()
    for name in TINY_FILES:
        with xr.open_dataset(ref / name) as ds:
            for attr in ("study_name", "step_name", "step_kind", "study_text", "study_sha256",
                         "robot", "gait", "integrator", "monkeystudy_version", "git_revision",
                         "library_versions", "history", "Conventions"):
                assert attr in ds.attrs, (name, attr)
            assert ds.attrs["study_text"] == text
            assert ds.attrs["Conventions"] == "CF-1.10"
            for v in ds.variables:
                assert "units" in ds[v].attrs and "long_name" in ds[v].attrs, (name, v)
            assert ds["status"].attrs["flag_meanings"].split()[0] == "ok"
    with xr.open_dataset(ref / "map.nc") as ds:
        assert ds["error"].dims == ("dtheta1", "dtheta2") and ds["error"].shape == (7, 9)
        assert 0.0 < ds.attrs["skipped_fraction"] < 1.0
        assert np.all(np.isnan(ds["error"].values[ds["status"].values != 0]))
        for v in ("t_switch", "t_motor", "t_end"):
            assert ds[v].attrs["units"] == "s"
        for v in ("steps", "nfev", "rejected"):
            assert ds[v].dtype == np.int32
    with xr.open_dataset(ref / "pts.nc") as ds:
        assert ds["error"].dims == ("point",)
        assert set(ds.coords) >= {"dtheta1", "dtheta2"}
        np.testing.assert_array_equal(ds["dtheta1"].values, [0.9, 1.0, 0.1])
    with xr.open_dataset(ref / "best.nc") as ds:
        assert ds.sizes["start"] == 2
        assert ds["iterate_error"].dims == ("start", "iteration")
        for a in ("method", "xatol", "fatol", "start", "converged", "message"):
            assert a in ds.attrs
    with xr.open_dataset(ref / "cycles.nc") as ds:
        assert ds.sizes["cycle"] == 3 and list(ds["cycle"].values) == [1, 2, 3]
        for v in ("error", "kinetic_energy", "pivot_height", "x_advance", "t_cross"):
            assert ds[v].dims == ("cycle",)
        assert ds["A"].dims == ("sample", "xy") and "time" in ds.coords
        assert ds["status"].ndim == 0
        for a in ("t_switch", "t_motor", "controller", "sample_dt"):
            assert a in ds.attrs


def test_unchanged_study_does_no_work(tiny_reference):
    study, ref = tiny_reference
    before = {p.name: (p.stat().st_ino, p.stat().st_mtime_ns) for p in ref.glob("*.nc")}
    summary = run_study(load_study(study), ref, workers=2)
    assert summary.written == [] and summary.blocks_computed == 0
    assert len(summary.up_to_date) == len(TINY_FILES)
    after = {p.name: (p.stat().st_ino, p.stat().st_mtime_ns) for p in ref.glob("*.nc")}
    assert before == after


def test_dry_run_plan_touches_nothing(tmp_path):
    study = write_study(tmp_path)
    out = tmp_path / "out"
    plan = plan_study(load_study(study), out)
    text = plan.describe()
    assert "map [grid] -> map.nc: 7 of 7 blocks to do" in text
    assert "b000000..b000006" in text
    assert "pts [grid] -> pts.nc: 2 of 2 blocks" in text
    assert not out.exists()


def test_changed_step_reruns_it_and_its_dependents_only(tiny_reference, tmp_path):
    """Step keys: a new block size for ``map`` reruns map and the steps built on it (best,
    cycles) but not ``pts``; shards under any other key are dropped, never used; and the
    results do not depend on the block size."""
    study, ref = tiny_reference
    out = tmp_path / "out"
    for name in TINY_FILES:
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_bytes((ref / name).read_bytes())
    # shards of some other step key: garbage that must be dropped
    stale = out / ".map.parts" / "0123456789abcdef"
    stale.mkdir(parents=True)
    np.savez(stale / "b000000.npz", lo=0, hi=10, error=np.zeros(10))
    edited = write_study(tmp_path, TINY.replace("block_size: 10", "block_size: 7"),
                         "edited.yaml")
    loaded = load_study(edited)
    plan = plan_study(loaded, out)
    assert {s.name: s.up_to_date for s in plan.steps} == \
        {"map": False, "pts": True, "best": False, "cycles": False}
    assert all(not s.saved for s in plan.steps)
    pts_inode = (out / "pts.nc").stat().st_ino
    summary = run_study(loaded, out, workers=2)
    assert sorted(p.name for p in summary.written) == ["best.nc", "cycles.nc", "map.nc"]
    assert (out / "pts.nc").stat().st_ino == pts_inode
    assert not stale.exists() and not (out / ".map.parts").exists()
    with xr.open_dataset(out / "map.nc") as a, xr.open_dataset(ref / "map.nc") as b:
        assert a["error"].values.tobytes() == b["error"].values.tobytes()
        assert a.attrs["step_sha256"] != b.attrs["step_sha256"]
    for name in ("best.nc", "cycles.nc"):
        with xr.open_dataset(out / name) as a, xr.open_dataset(ref / name) as b:
            for v in a.data_vars:
                np.testing.assert_array_equal(a[v].values, b[v].values)
    # a rerun of the original text replaces the rerun files (new inodes), never rewrites them
    ino = (out / "map.nc").stat().st_ino
    run_study(load_study(study), out, workers=2)
    assert (out / "map.nc").stat().st_ino != ino
    assert_same_datasets(ref, out, TINY_FILES)


def test_description_and_robot_edits(tiny_reference, tmp_path):
    """Free text changes no step key; the robot, gait or integrator changes every one."""
    study, ref = tiny_reference
    described = write_study(tmp_path, TINY.replace("small study", "small study, edited"),
                            "described.yaml")
    assert all(s.up_to_date for s in plan_study(load_study(described), ref).steps)
    robot = ("robot: seed2009", "robot:\n  gravity: 9.80\n  links:\n"
             "    - {mass: 1.0, length: 0.61, com: 0.543754, inertia: 0.01808704}\n"
             "    - {mass: 1.0, length: 0.61, com: 0.066246, inertia: 0.01808704}")
    for old, new in (robot, ("tick: 0.001", "tick: 0.0005"), ("rtol: 1.0e-8", "rtol: 1.0e-9")):
        assert old in TINY
        edited = write_study(tmp_path, TINY.replace(old, new), "edited.yaml")
        assert not any(s.up_to_date for s in plan_study(load_study(edited), ref).steps), new


# --- atomic writes ------------------------------------------------------------------------------
def test_shard_write_is_atomic(tmp_path, monkeypatch):
    b = B.Block(3, 30, 40)
    arrays = {"error": np.arange(10.0)}

    def boom(fh, **kw):
        fh.write(b"partial")
        raise OSError("disk full")

    monkeypatch.setattr(B.np, "savez", boom)
    with pytest.raises(OSError):
        B.write_shard(tmp_path, b, arrays)
    assert list(tmp_path.iterdir()) == []


def test_netcdf_write_is_atomic_and_keeps_the_old_file(tmp_path):
    path = tmp_path / "x.nc"
    with D.atomic_netcdf(path) as nc:
        nc.setncattr("version", 1)
    old = path.read_bytes()
    with pytest.raises(RuntimeError):
        with D.atomic_netcdf(path) as nc:
            nc.setncattr("version", 2)
            raise RuntimeError("interrupted while writing")
    assert path.read_bytes() == old
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.nc"]


def test_grid_consolidation_refuses_missing_blocks(tmp_path):
    a1, a2 = np.linspace(0, 1, 2), np.linspace(0, 1, 3)
    blk = {k: np.zeros(3, dt) for k, dt in grid.HORIZONTAL_VARIABLES.items()}
    with pytest.raises(RuntimeError, match="3 of 6 points"):
        grid.write_grid(tmp_path / "g.nc", {}, axes=(a1, a2), blocks=[(0, blk)])
    assert list(tmp_path.iterdir()) == []


# --- kill and resume -------------------------------------------------------------------------------
KILL_STUDY = """\
schema_version: 1
name: killme
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
integrator: {rtol: 1.0e-8, atol: 1.0e-10}
steps:
  - {name: map, kind: grid, block_size: 150,
     dtheta1: {start: 0.0, stop: 3.0, num: 121}, dtheta2: {start: 9.0, stop: 14.0, num: 151}}
  - {name: best, kind: refine, start: {from: map, best: 1}, maxiter: 10}
"""


def _shards(out: Path) -> list[Path]:
    return list(out.glob(".map.parts/*/b*.npz"))


def _start(study: Path, out: Path, pause: int) -> subprocess.Popen:
    """The run as a subprocess, paused once it has computed ``pause`` blocks (the test hook
    ``$MONKEYSTUDY_PAUSE_AFTER_BLOCKS``), so every signal below lands at a known point."""
    return subprocess.Popen([sys.executable, "-m", "monkeystudy", "run", str(study),
                             "--out", str(out), "--workers", "1"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True,
                            env={**os.environ, "MONKEYSTUDY_PAUSE_AFTER_BLOCKS": str(pause)})


#: a hang guard for the subprocess runs, not a timing: on a loaded 2-core machine a resumed run
#: took over 60 s in a clean-clone CI run while a benchmark ran beside it
HANG = 300


def _wait_until_paused(proc: subprocess.Popen) -> str:
    """The run's standard error up to its pause line (fails if it ends first)."""
    err = []
    for line in proc.stderr:
        err.append(line)
        if "waiting for a signal" in line:
            return "".join(err)
    proc.wait(timeout=HANG)
    pytest.fail(f"the run ended before its pause: rc {proc.returncode}\n{''.join(err)}")


def _children(pid: int) -> list[int]:
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def _pool_workers(driver: int) -> list[int]:
    """The local pool's worker processes: children of the driver's forkserver, or (start
    method fork) the driver's own children other than multiprocessing's resource tracker."""
    workers = []
    for child in _children(driver):
        try:
            cmd = (Path("/proc") / str(child) / "cmdline").read_bytes()
        except OSError:
            continue
        if b"forkserver" in cmd:
            workers += _children(child)
        elif b"resource_tracker" not in cmd:
            workers.append(child)
    return workers


def _kill_group(proc: subprocess.Popen) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait(timeout=30)


@pytest.mark.slow
def test_resume_after_ctrl_c_sigterm_kill9_and_dead_worker_is_bit_identical(tmp_path):
    study = write_study(tmp_path, KILL_STUDY, "kill.yaml")
    out = tmp_path / "resumed"
    n_blocks = -(-121 * 151 // 150)

    # 1. Ctrl-C (SIGINT to the whole process group), then SIGTERM to the driver: exit code 3,
    #    finished blocks kept
    first = 0
    for sig, group in ((signal.SIGINT, True), (signal.SIGTERM, False)):
        proc = _start(study, out, pause=4)
        try:
            _wait_until_paused(proc)
            if group:
                os.killpg(proc.pid, sig)
            else:
                proc.send_signal(sig)
            _, err = proc.communicate(timeout=HANG)
        finally:
            _kill_group(proc)
        assert proc.returncode == 3, err
        assert "rerun the same command to resume" in err and "Traceback" not in err
        assert len(_shards(out)) >= first + 4
        first = len(_shards(out))
    assert first < n_blocks
    assert not (out / "map.nc").exists()

    # 2. kill -9 of the driver and its workers: nothing to clean up but temp files
    proc = _start(study, out, pause=8)
    try:
        _wait_until_paused(proc)
    finally:
        _kill_group(proc)
    second = len(_shards(out))
    assert first + 8 <= second < n_blocks
    assert not (out / "map.nc").exists()

    # 3. a pool worker dies (the OOM killer, say): exit code 3, finished blocks kept
    if sys.platform.startswith("linux"):
        proc = _start(study, out, pause=4)
        try:
            _wait_until_paused(proc)
            workers = _pool_workers(proc.pid)
            assert workers, "no pool worker found"
            os.kill(workers[0], signal.SIGKILL)
            _, err = proc.communicate(timeout=HANG)
        finally:
            _kill_group(proc)
        assert proc.returncode == 3, err
        assert "a worker died" in err
        second = len(_shards(out))

    # 4. the rerun resumes: only the missing blocks are computed
    summary = run_study(load_study(study), out, workers=2)
    assert summary.blocks_reused >= second
    assert summary.blocks_computed == n_blocks - summary.blocks_reused
    assert not list(out.glob(".*.parts"))

    # 5. identical, bit for bit, to a clean uninterrupted run
    clean = tmp_path / "clean"
    run_study(load_study(study), clean, workers=2)
    assert_same_datasets(clean, out, ["map.nc", "best.nc"])


# --- failures and lost workers -------------------------------------------------------------------
class _FakeExecutor:
    """Every task ends with the given exception (a lost worker or a bug)."""

    def __init__(self, exc: BaseException):
        self.exc = exc

    def submit(self, fn, *args, **kwargs):
        from concurrent.futures import Future
        f = Future()
        f.set_exception(self.exc)
        return f

    def shutdown(self, wait=True, **kw):
        pass


def _fake_pool(exc):
    from contextlib import contextmanager

    @contextmanager
    def fake(workers=None, scheduler=None, warm_up=None):
        if warm_up is not None:
            warm_up()
        yield Pool(_FakeExecutor(exc), 2, "fake", lambda: None)
    return fake


def test_lost_worker_is_an_interruption(tmp_path, monkeypatch):
    from concurrent.futures.process import BrokenProcessPool
    monkeypatch.setattr(R, "open_pool", _fake_pool(BrokenProcessPool("worker died")))
    with pytest.raises(RunInterrupted, match="rerun the same command to resume"):
        run_study(load_study(write_study(tmp_path)), tmp_path / "out")
    assert not list((tmp_path / "out").glob("*.nc"))


def test_task_error_fails_the_run(tmp_path, monkeypatch):
    monkeypatch.setattr(R, "open_pool", _fake_pool(ValueError("a bug")))
    with pytest.raises(RunFailed, match="ValueError: a bug"):
        run_study(load_study(write_study(tmp_path)), tmp_path / "out")


#: a failing step first (its task refuses on the worker: no gait at its points), a refine of
#: a grid without a gait (refused when it starts), a stability run built on it, and an
#: independent grid last
FAILING = """\
schema_version: 1
name: failing
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
integrator: {rtol: 1.0e-8, atol: 1.0e-10}
steps:
  - {name: wp, kind: work_precision, points: [[0.0, 0.0]], methods: [rk45], rtols: [1.0e-6],
     repeat: 1, scipy_methods: [RK45], scipy_rtols: [1.0e-6]}
  - {name: nogait, kind: grid, dtheta1: {start: 0.0, stop: 0.1, num: 2},
     dtheta2: {start: 0.0, stop: 0.1, num: 2}}
  - {name: r, kind: refine, start: {from: nogait, best: 1}}
  - {name: s, kind: stability, from: r, cycles: 2}
  - {name: map, kind: grid, dtheta1: {start: 0.8, stop: 1.0, num: 2},
     dtheta2: {start: 10.8, stop: 11.0, num: 2}}
"""


def test_a_failed_step_stops_only_the_steps_built_on_it(tmp_path):
    """Every step whose dependencies succeeded runs; the failures are reported together at
    the end (StepsFailed, exit 1), each failed or not-run step leaving its marker with the
    reason; a rerun starts from no marker and leaves the same ones."""
    from monkeystudy.study.failures import read_failures
    from monkeystudy.study.runner import StepsFailed

    study = write_study(tmp_path, FAILING, "failing.yaml")
    out = tmp_path / "out"
    with pytest.raises(StepsFailed) as err:
        run_study(load_study(study), out, workers=1)
    summary = err.value.summary
    assert sorted(p.name for p in out.glob("*.nc")) == ["map.nc", "nogait.nc"]
    assert sorted(p.name for p in summary.written) == ["map.nc", "nogait.nc"]
    assert set(summary.failed) == {"wp", "r"}
    assert summary.failed["wp"].startswith("no gait at any of the 1 point")
    assert "none of its 4 points has a gait" in summary.failed["r"]
    assert summary.not_run == {"s": "step 'r', which it depends on, failed"}
    text = str(err.value)
    assert text.startswith("2 steps failed, 1 not run:") and "Traceback" not in text
    assert "\n  s: not run: step 'r', which it depends on, failed" in text
    markers = read_failures(out)
    assert {n: (m.state, m.kind) for n, m in markers.items()} == {
        "wp": ("failed", "work_precision"), "r": ("failed", "refine"),
        "s": ("not_run", "stability")}
    assert markers["r"].reason == summary.failed["r"]
    assert markers["s"].study_text == FAILING and markers["s"].study_name == "failing"
    from monkeystudy.study.inspect import summarize_folder
    shown = summarize_folder(out)                  # monkeystudy inspect: every step accounted
    assert "3 steps of the last run wrote no dataset:" in shown
    assert f"\n  r [refine] failed: {summary.failed['r']}" in shown
    assert "\n  s [stability] not run: step 'r', which it depends on, failed" in shown
    with pytest.raises(StepsFailed):
        run_study(load_study(study), out, workers=1)
    assert set(read_failures(out)) == {"wp", "r", "s"}
    # the failing steps gone from the study: the run is up to date, no marker is left
    fixed = FAILING.split("  - {name: wp")[0] + "  - {name: map" + FAILING.split("- {name: map")[1]
    run_study(load_study(write_study(tmp_path, fixed, "fixed.yaml")), out, workers=1)
    assert read_failures(out) == {}


def test_progress_is_rich_on_a_terminal_and_plain_otherwise():
    import io
    from monkeystudy.study.progress import PlainReporter, RichReporter, make_reporter

    class Tty(io.StringIO):
        def isatty(self):
            return True

    plain = io.StringIO()
    rep = make_reporter(plain)
    assert isinstance(rep, PlainReporter)
    rep.start("map", 4)
    for _ in range(4):
        rep.advance("map")
    rep.finish("map", "ok")
    assert "map: 4/4 blocks (100%)" in plain.getvalue() and "map: done" in plain.getvalue()
    rich = make_reporter(Tty())
    assert isinstance(rich, RichReporter)
    rich.start("map", 4)
    rich.advance("map")
    rich.close()


def test_integrator_controller_reaches_the_workers(tmp_path):
    """``integrator.controller: pi`` is what the pool's workers integrate with, and the dataset
    records it (a spec that dropped it would silently run scipy's controller)."""
    from monkeystudy import Integrator, evaluate_gaits

    pts = [[0.9, 10.9], [1.0, 11.0], [1.2, 11.3]]
    text = ("schema_version: 1\nname: pi\nrobot: seed2009\n"
            "gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.0}\n"
            "integrator: {rtol: 1.0e-8, atol: 1.0e-10, controller: pi}\n"
            f"steps:\n  - {{name: pts, kind: grid, points: {pts}, block_size: 2}}\n")
    out = tmp_path / "out"
    run_study(load_study(write_study(tmp_path, text, "pi.yaml")), out, workers=2)
    with xr.open_dataset(out / "pts.nc") as ds:
        assert '"controller": "pi"' in ds.attrs["integrator"]
        got = ds["error"].values
        rejected = ds["rejected"].values
    want = {c: evaluate_gaits(pts, integrator=Integrator(rtol=1e-8, atol=1e-10, controller=c))
            for c in ("pi", "scipy")}
    assert np.array_equal(got, want["pi"]["error"])
    assert np.array_equal(rejected, want["pi"]["rejected"])
    assert not np.array_equal(got, want["scipy"]["error"])


class _Lines(R.Reporter):
    def __init__(self):
        self.lines = []

    def log(self, message: str) -> None:
        self.lines.append(message)


def test_first_run_says_it_compiles_and_a_cached_run_does_not(tmp_path, monkeypatch):
    """The compile line depends on the marker :func:`load_kernels` leaves in the kernel
    cache: without it (a first run with this code) the run says it compiles, once. The
    markers go to an empty folder here (the compiled kernels stay where they are)."""
    markers = tmp_path / "markers"
    markers.mkdir()
    monkeypatch.setattr(R, "KERNEL_CACHE_DIR", str(markers))
    helpers = []   # a first run compiles the loop's callees on the idle core, a cached one not
    monkeypatch.setattr(R.compiling, "start", lambda method, runs=None: helpers.append(method))
    recorded = []   # how long it took, for the next first run's estimate
    monkeypatch.setattr(R.compiling, "record_compile_time",
                        lambda what, seconds: recorded.append(what))
    loaded = load_study(write_study(tmp_path))
    first = _Lines()
    run_study(loaded, tmp_path / "a", workers=1, reporter=first)
    assert any(line.startswith("compiling the kernels this study uses (dop853")
               for line in first.lines), first.lines
    assert list(markers.glob("loaded-dop853*"))   # each method compiles its own kernels
    assert helpers == ["dop853"] and recorded == ["dop853-runs"]
    assert any(line.startswith("compiled the kernels in") for line in first.lines)
    again = _Lines()
    run_study(loaded, tmp_path / "b", workers=1, reporter=again)
    assert not any("compiling" in line for line in again.lines), again.lines
    assert helpers == ["dop853"]


def test_steps_that_run_no_gait_load_their_own_integrators_kernels(tmp_path, monkeypatch):
    """A study whose steps run no gait (hardware_replay) has no gait to evaluate: the warm-up
    before fanning out loads the controller runs of its steps' own integrator, without the
    gait evaluation, and leaves a marker of its own; a study whose steps run its gait loads
    the gait's kernels with the study's integrator, as ever."""
    from monkeystudy.analysis.measured_replay import REPLAY_INTEGRATOR
    from monkeystudy.study.spec import gait_spec

    root = Path(__file__).resolve().parents[2]
    loaded = load_study(root / "studies" / "acromonk_smoke.yaml")
    plan = plan_study(loaded, tmp_path / "acro")
    specs = R.kernel_specs(gait_spec(loaded.study), plan.steps)
    assert [(ks.has_gait, ks.integrator, [s.name for s in steps])
            for ks, steps in specs] == [(False, REPLAY_INTEGRATOR, ["replay"])]
    markers = tmp_path / "markers"
    markers.mkdir()
    monkeypatch.setattr(R, "KERNEL_CACHE_DIR", str(markers))
    R.load_kernels(specs[0][0], runs=True)
    assert [p.name for p in markers.iterdir()] == ["loaded-dop853-runs-without-gait"]
    from monkeystudy.study import parse_study
    gaited = parse_study("schema_version: 1\nname: g\nrobot: seed2009\n"
                         "gait: {kind: horizontal, motor_torque: 0.6354}\n"
                         "steps: [{name: g, kind: refine, start: [0.9, 10.9]}]\n")
    spec = gait_spec(gaited.study)
    steps = plan_study(gaited, tmp_path / "g").steps
    assert spec.has_gait and R.kernel_specs(spec, steps) == [(spec, steps)]
    # a step that runs no gait beside one that does: the study's spec loads its kernels when
    # its integrator's method is the study's, else a spec without a gait of its own does
    acro = (root / "studies" / "acromonk_smoke.yaml").read_text()
    for method, own in (("dop853", False), ("rk45", True)):
        text = acro.replace("steps:\n", "gait: {kind: horizontal, motor_torque: 0.6354}\n"
                            f"integrator: {{method: {method}}}\nsteps:\n"
                            "  - {name: g, kind: refine, start: [0.9, 10.9]}\n")
        both = parse_study(text, "both.yaml", root / "studies" / "both.yaml")
        spec = gait_spec(both.study)
        steps = plan_study(both, tmp_path / method).steps
        got = [(ks.has_gait, ks.integrator.method, [s.name for s in st])
               for ks, st in R.kernel_specs(spec, steps)]
        assert got == ([(True, method, ["g"]), (False, "dop853", ["replay"])] if own else
                       [(True, method, ["g", "replay"])]), got


def test_ctrl_c_while_a_dataset_is_written_waits_for_it(tmp_path, monkeypatch):
    """A Ctrl-C that lands while a step writes its dataset takes effect once the file is
    complete: the run stops (exit 3), the dataset written is whole and current, the rerun
    does the rest."""
    study = load_study(write_study(tmp_path))
    original = grid.write_grid

    def write_interrupted(path, attrs, **kw):
        os.kill(os.getpid(), signal.SIGINT)      # lands in the middle of the write
        return original(path, attrs, **kw)
    monkeypatch.setattr(grid, "write_grid", write_interrupted)
    with pytest.raises(RunInterrupted, match="rerun the same command to resume"):
        run_study(study, tmp_path / "out", workers=1)
    written = sorted(p.name for p in (tmp_path / "out").glob("*.nc"))
    assert written and set(written) < set(TINY_FILES)
    for name in written:
        with xr.open_dataset(tmp_path / "out" / name) as ds:
            assert ds.attrs["step_name"] == name[:-3]
    monkeypatch.setattr(grid, "write_grid", original)
    plan = plan_study(study, tmp_path / "out")
    assert all(s.up_to_date for s in plan.steps if s.path.name in written)
    summary = run_study(study, tmp_path / "out", workers=1)
    assert sorted(p.name for p in summary.written) == sorted(set(TINY_FILES) - set(written))
