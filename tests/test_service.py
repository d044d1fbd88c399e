"""``monkeystudy serve`` and ``monkeystudy run --server``: a real server process on a socket in a
temporary folder; the client through ``python -m monkeystudy`` (the console script's path)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from click.testing import CliRunner

from monkeystudy import __main__ as entry
from monkeystudy.service import client as service
from monkeystudy.cli import app

ROOT = Path(__file__).resolve().parents[1]
SMOKE = ROOT / "studies" / "smoke.yaml"

# a map long enough (~1-2 s on two workers) to be interrupted between its 100 blocks
LONG_MAP = """schema_version: 1
name: long_map
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354}
integrator: {method: dop853, rtol: 1.0e-8, atol: 1.0e-10, max_time: 3.0}
steps:
  - {name: map, kind: grid, dtheta1: {start: 0.0, stop: 3.0, num: 200},
     dtheta2: {start: 9.0, stop: 14.0, num: 250}, block_size: 500}
"""


def _client(*args, cwd=None, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "monkeystudy", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, timeout=600, **kw)


def _wait_ready(sock: str, proc: subprocess.Popen, timeout: float = 600.0) -> dict:
    """The server's ping answer, once it listens (a cold kernel cache compiles first)."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if proc.poll() is not None:
            raise AssertionError(f"server exited {proc.returncode}: {proc.log.read_text()}")
        try:
            return service.request(sock, "ping", timeout=5.0)
        except (service.ServiceError, OSError):
            time.sleep(0.05)
    raise AssertionError("server did not start")


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    folder = tmp_path_factory.mktemp("serve")
    sock = str(folder / "s.sock")
    # the server's (and its workers') output goes to a file: a pipe nobody reads until the
    # end would block them once full
    log = open(folder / "serve.log", "w+")
    proc = subprocess.Popen([sys.executable, "-m", "monkeystudy", "serve", "--socket", sock,
                             "--workers", "2"], stdout=log, stderr=subprocess.STDOUT, text=True)
    proc.log = folder / "serve.log"
    info = _wait_ready(sock, proc)
    yield sock, proc, info
    if proc.poll() is None:
        proc.terminate()
        proc.wait(timeout=60)
    log.close()


def _same_datasets(a: Path, b: Path) -> None:
    names = sorted(p.name for p in a.glob("*.nc"))
    assert names and names == sorted(p.name for p in b.glob("*.nc"))
    for name in names:
        with xr.open_dataset(a / name) as x, xr.open_dataset(b / name) as y:
            assert set(x.variables) == set(y.variables), name
            for v in x.variables:
                assert x[v].values.tobytes() == y[v].values.tobytes(), (name, v)
            assert x.attrs["step_sha256"] == y.attrs["step_sha256"]


def test_served_run_writes_the_direct_runs_datasets(server, tmp_path):
    sock, proc, info = server
    assert info["workers"] == 2 and info["pid"] == proc.pid
    direct = tmp_path / "direct"
    res = CliRunner().invoke(app, ["run", str(SMOKE), "--out", str(direct), "--workers", "2"])
    assert res.exit_code == 0, res.output
    # relative study and output paths are the client's (its cwd), not the server's
    res = _client("run", "studies/smoke.yaml", "--out", tmp_path / "served", "--server",
                  "--socket", sock, cwd=ROOT)
    assert res.returncode == 0, res.stderr
    assert "wrote" in res.stdout and "coarse_map: done" in res.stderr
    _same_datasets(direct, tmp_path / "served")
    with xr.open_dataset(tmp_path / "served" / "gait1.nc") as ds:
        assert f"--server --socket {sock}" in ds.attrs["history"]
    # a rerun through the server finds everything up to date
    res = _client("run", SMOKE, "--out", tmp_path / "served", "--server", "--socket", sock)
    assert res.returncode == 0 and res.stdout.count("up to date") == 5, res.stdout


def test_served_default_output_folder_is_relative_to_the_client(server, tmp_path):
    sock = server[0]
    study = tmp_path / "tiny.yaml"
    study.write_text(LONG_MAP.replace("num: 200", "num: 3").replace("num: 250", "num: 4")
                     .replace("long_map", "tiny"))
    res = _client("run", "tiny.yaml", "--server", f"--socket={sock}", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "outputs" / "tiny" / "map.nc").is_file()
    assert "wrote outputs/tiny/map.nc" in res.stdout


def test_served_invalid_study_exits_2_and_the_server_goes_on(server, tmp_path):
    sock = server[0]
    bad = tmp_path / "bad.yaml"
    bad.write_text(SMOKE.read_text().replace("num: 9", "num: 0"))
    res = _client("run", bad, "--out", tmp_path / "o", "--server", "--socket", sock)
    assert res.returncode == 2
    assert f"{bad}:13: steps[0].dtheta1.num: must be >= 1, got 0" in res.stderr
    assert not (tmp_path / "o").exists()
    res = _client("run", tmp_path / "missing.yaml", "--server", "--socket", sock)
    assert res.returncode == 2 and "no such file" in res.stderr
    assert service.request(sock, "ping")["pid"] == server[1].pid


def test_served_dry_run(server, tmp_path):
    res = _client("run", SMOKE, "--out", tmp_path / "never", "--dry-run", "--server",
                  "--socket", server[0])
    assert res.returncode == 0, res.stderr
    assert "coarse_map [grid] -> coarse_map.nc: 9 of 9 blocks to do" in res.stdout
    assert not (tmp_path / "never").exists()


def test_options_that_choose_a_pool_are_refused_with_server(server, tmp_path):
    res = _client("run", SMOKE, "--workers", "2", "--server", "--socket", server[0])
    assert res.returncode == 2 and "not with --server" in res.stderr


def test_no_server_exits_1_and_says_how_to_start_one(tmp_path):
    sock = tmp_path / "none.sock"
    res = _client("run", SMOKE, "--server", "--socket", sock)
    assert res.returncode == 1
    assert f"no monkeystudy server at {sock}" in res.stderr
    assert "monkeystudy serve --socket" in res.stderr


def test_a_second_server_on_the_same_socket_is_refused(server):
    res = _client("serve", "--socket", server[0])
    assert res.returncode == 2 and "already listening" in res.stderr


def test_an_impossible_socket_path_is_refused_at_once(tmp_path):
    res = _client("serve", "--socket", tmp_path / ("x" * 120) / "s.sock")
    assert res.returncode == 2 and "socket path too long" in res.stderr


def test_other_code_is_refused(server, tmp_path, monkeypatch):
    """A client whose package differs from the server's gets exit 1, never a dataset."""
    from monkeystudy.study import provenance
    monkeypatch.setattr(provenance, "source_sha256", lambda: "0" * 64)
    err = tmp_path / "err.txt"
    with open(err, "w") as fh:
        code = service.submit_run(server[0], SMOKE, tmp_path / "o", command="test",
                                  stdout=fh, stderr=fh)
    assert code == 1 and "restart it" in err.read_text()
    assert not (tmp_path / "o").exists()


def test_interrupted_client_stops_the_run_and_a_rerun_resumes(server, tmp_path):
    sock = server[0]
    study = tmp_path / "long.yaml"
    study.write_text(LONG_MAP)
    out = tmp_path / "o"
    # the server holds the run after 5 computed blocks (the test hook, sent with the request),
    # so the interruption lands at a known point whatever the machine's speed
    client = subprocess.Popen([sys.executable, "-m", "monkeystudy", "run", str(study), "--out",
                               str(out), "--server", "--socket", sock], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True,
                              env={**os.environ, "MONKEYSTUDY_PAUSE_AFTER_BLOCKS": "5"})
    parts = out / ".map.parts"
    for line in client.stderr:
        if "waiting for a signal" in line:
            break
    assert client.poll() is None, "the run ended before it could be interrupted"
    client.send_signal(signal.SIGINT)
    _, err = client.communicate(timeout=300)
    assert client.returncode == 3, err
    assert "asking the server to stop the run" in err
    # the server's own last words (the client waited for them), not the client's fallback
    assert "monkeystudy: interrupted; " in err and "finished blocks saved" in err, err
    assert "closed the connection" not in err
    assert not (out / "map.nc").exists()
    saved = len(list(parts.glob("*/*.npz")))
    assert 5 <= saved < 100
    # the same server resumes it (its pool was stopped with the run and is forked anew)
    res = _client("run", study, "--out", out, "--server", "--socket", sock)
    assert res.returncode == 0, res.stderr
    assert f"({saved} already saved)" in res.stderr
    res = _client("run", study, "--out", tmp_path / "whole", "--server", "--socket", sock)
    assert res.returncode == 0, res.stderr
    _same_datasets(out, tmp_path / "whole")


def test_resident_pool_is_renewed_when_a_run_loads_new_kernels(monkeypatch):
    from monkeystudy.study import runner

    class FakePool:
        renewed = aborted = 0

        def renew(self):
            self.renewed += 1

        def abort(self):
            self.aborted += 1

    loaded = [3]
    monkeypatch.setattr(runner, "loaded_kernels", lambda: loaded[0])
    pool = FakePool()
    with runner.resident_pool(pool, lambda: None):      # nothing new: the workers have it all
        pass
    assert (pool.renewed, pool.aborted) == (0, 0)

    def load_more():
        loaded[0] += 2
    with runner.resident_pool(pool, load_more):
        pass
    assert (pool.renewed, pool.aborted) == (1, 0)
    with pytest.raises(KeyboardInterrupt):           # a run that does not finish stops them
        with runner.resident_pool(pool, lambda: None):
            raise KeyboardInterrupt
    assert pool.aborted == 1


def test_thin_client_parser_matches_the_run_command():
    """The served-run short path parses exactly ``run``'s options (names and arity)."""
    run = app.commands["run"]
    cli_opts = {opt: not p.is_flag for p in run.params if p.param_type_name == "option"
                for opt in p.opts}
    cli_args = [p.name for p in run.params if p.param_type_name == "argument"]
    parser = entry.served_run_parser()
    ours = {opt: a.nargs != 0 for a in parser._actions for opt in a.option_strings}
    assert ours == cli_opts
    assert [a.dest for a in parser._actions if not a.option_strings] == cli_args
    assert ours["--out"] and ours["--socket"] and not ours["--server"]


@pytest.mark.parametrize("argv", [
    ["run", "s.yaml"],                                   # not served
    ["validate", "s.yaml", "--server"],                  # not run
    ["run", "s.yaml", "--server", "--help"],             # help: the full command line
    ["run", "s.yaml", "--server", "--workers", "2"],     # refused there, with a message
    ["run", "s.yaml", "--server", "--bogus"],            # a mistake: reported there
    ["run", "--server"],                                 # no study
    ["run", "s.yaml", "--server", "--socket"],           # no socket path
])
def test_thin_client_leaves_other_command_lines_to_the_cli(argv):
    assert entry._served_run(argv) is None


def test_stop_removes_the_socket_and_ends_the_server(server):
    """Last in this module: ``serve --stop`` ends the shared server cleanly."""
    sock, proc, _ = server
    res = _client("serve", "--status", "--socket", sock)
    assert res.returncode == 0 and f"server pid {proc.pid}" in res.stdout
    res = _client("serve", "--stop", "--socket", sock)
    assert res.returncode == 0 and "stopping" in res.stdout
    try:
        code = proc.wait(timeout=60)
    except subprocess.TimeoutExpired:
        raise AssertionError(f"the server did not exit; its log:\n{proc.log.read_text()}") \
            from None
    assert code == 0, proc.log.read_text()
    assert not os.path.exists(sock)
    assert "stopped" in proc.log.read_text()
    np.testing.assert_equal(_client("serve", "--status", "--socket", sock).returncode, 1)
