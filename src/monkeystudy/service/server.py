"""The server side of ``monkeystudy serve`` (see :mod:`monkeystudy.service`): it loads the
kernels and forks a warm pool once, then runs the studies clients hand it, one at a time, with
the command line's own run path (:func:`monkeystudy.study.command.execute_run`)."""
from __future__ import annotations

import gc
import os
import signal
import socket
import sys
import threading
import time
import traceback
from pathlib import Path
from typing import Callable, TextIO

from .. import __version__
from ..exit_codes import EXIT_FAILED, EXIT_INVALID
from ..study import provenance
from ..study.command import execute_run, pause_from_env
from ..study.loader import StudyError, load_study, parse_study
from ..study.plan import default_out
from ..study.pool import local_pool
from ..study.progress import PlainReporter, count
from ..study.runner import load_kernels
from ..study.spec import gait_spec
from ..study.steps import REGISTRY
from .client import PROTOCOL, MessageReader, ServiceError, request, send_message


class ClientGone(KeyboardInterrupt):
    """The client of the current run half-closed or closed its connection."""


class StopServer(KeyboardInterrupt):
    """SIGINT or SIGTERM to the server: stop the run and the server."""


class LineStream:
    """A text stream that sends each line to the client as ``{key: line}`` (the reporter's
    output); a client that is gone is not an error here (the watcher stops the run)."""

    def __init__(self, send: Callable[[dict], None], key: str):
        self._send, self._key, self._buf = send, key, ""

    def write(self, text: str) -> int:
        self._buf += text
        while "\n" in self._buf:
            line, self._buf = self._buf.split("\n", 1)
            self._send({self._key: line})
        return len(text)

    def flush(self) -> None:
        pass

    def isatty(self) -> bool:
        return False


class Server:
    """The resident service (see the module docstring). :meth:`start` loads everything and
    binds the socket; :meth:`serve_forever` answers clients until ``stop`` or a signal."""

    def __init__(self, socket_path: str, workers: int | None = None,
                 log: TextIO | None = None):
        self.path = socket_path
        self.workers = workers
        self.log = log or sys.stderr
        self.pool = None
        self.sock: socket.socket | None = None
        self.code = ""
        self._stop = False
        self._stop_asked = False   # by a ``stop`` request (the pool is idle then)

    def _say(self, text: str) -> None:
        print(f"[monkeystudy serve] {text}", file=self.log, flush=True)

    def start(self) -> None:
        gc.disable()   # start-up allocates ~10^6 long-lived objects: see cli.run
        try:
            self._check_free()
            self.code = provenance.source_sha256()
            for kind in REGISTRY.values():  # pinned (cached) with the code they describe
                kind.code_sha256
            provenance.code_sha256()
            provenance.git_revision()       # pinned too: the datasets' provenance attrs
            provenance.library_versions()
            t0 = time.perf_counter()
            spec = gait_spec(parse_study(WARM_STUDY, "<warm-up>").study)
            load_kernels(spec, runs=True, variational=True)
            self._say(f"kernels loaded in {time.perf_counter() - t0:.1f} s")
            self.pool = local_pool(self.workers)   # forked now: the workers inherit it all
        finally:
            gc.enable()
        self._bind()
        self._say(f"pid {os.getpid()}, {count(self.pool.slots, 'worker')}, listening on {self.path} "
                  "(Ctrl-C or 'monkeystudy serve --stop' stops)")

    def _check_free(self) -> None:
        """Refuse a socket path that cannot work, before minutes of loading could."""
        if len(os.fsencode(self.path)) > 107:    # sockaddr_un.sun_path, with its NUL
            raise ServiceError(f"socket path too long for a Unix socket ({len(self.path)} > "
                               f"107 bytes): {self.path}")
        os.makedirs(os.path.dirname(os.path.abspath(self.path)), mode=0o700, exist_ok=True)
        if os.path.exists(self.path):
            try:
                msg = request(self.path, "ping", timeout=2.0)
            except (ServiceError, OSError, ValueError):
                os.unlink(self.path)      # a dead server's socket file
                return
            raise ServiceError(f"a monkeystudy server (pid {msg.get('pid')}) is already "
                               f"listening on {self.path}")

    def _bind(self) -> None:
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        old = os.umask(0o177)             # the socket file is born 0600
        try:
            sock.bind(self.path)
        finally:
            os.umask(old)
        sock.listen(16)
        self.sock = sock

    def serve_forever(self) -> None:
        def stop(signum, frame):
            self._stop = True
            raise StopServer

        def client_gone(signum, frame):
            raise ClientGone

        previous = {s: signal.signal(s, h) for s, h in ((signal.SIGINT, stop),
                                                         (signal.SIGTERM, stop),
                                                         (signal.SIGUSR1, client_gone))}
        try:
            while not self._stop:
                try:
                    conn, _ = self.sock.accept()
                except ClientGone:       # a late signal from a finished run's watcher
                    continue
                except StopServer:
                    break
                with conn:
                    try:
                        self._handle(conn)
                    except ClientGone:
                        pass
                    except StopServer:
                        break
                    except Exception as exc:  # a bug: tell the client, keep serving
                        text = "".join(traceback.format_exception(exc))
                        self._say(f"request failed:\n{text}")
                        self._reply(conn, {"err": f"monkeystudy serve: request failed: "
                                                  f"{type(exc).__name__}: {exc}"}, EXIT_FAILED)
        finally:
            for s, h in previous.items():
                signal.signal(s, h)
            self.close(idle=self._stop_asked)

    def close(self, idle: bool = False) -> None:
        """Unlink the socket and stop the workers: at once (``abort``), or, when ``idle``
        (a ``stop`` request, answered between runs), by letting them exit."""
        if self.sock is not None:
            self.sock.close()
            self.sock = None
            try:
                os.unlink(self.path)
            except FileNotFoundError:
                pass
        if self.pool is not None:
            if idle and self.pool.usable:
                self.pool.close()
            else:
                self.pool.abort()
            self.pool = None
        self._say("stopped")

    # one connection -------------------------------------------------------------------------
    def _handle(self, conn: socket.socket) -> None:
        conn.settimeout(10.0)
        try:
            req = MessageReader(conn).next()
        except (OSError, ValueError) as exc:
            self._say(f"bad request: {exc}")
            return
        conn.settimeout(None)
        if not isinstance(req, dict) or req.get("protocol") != PROTOCOL:
            self._reply(conn, {"err": f"monkeystudy serve speaks protocol {PROTOCOL}; this "
                                      "client does not (same installation?)"}, EXIT_INVALID)
            return
        op = req.get("op")
        if op == "ping":
            send_message(conn, {"pid": os.getpid(), "workers": self.pool.slots if self.pool else 0,
                         "source_sha256": self.code, "version": __version__})
        elif op == "stop":
            send_message(conn, {"pid": os.getpid(), "stopping": True})
            self._stop = True
            self._stop_asked = True
        elif op == "run":
            self._run(conn, req)
        else:
            self._reply(conn, {"err": f"unknown request {op!r}"}, EXIT_INVALID)

    def _reply(self, conn, message: dict | None, code: int) -> None:
        try:
            if message is not None:
                send_message(conn, message)
            send_message(conn, {"exit": code})
        except OSError:
            pass

    def _run(self, conn: socket.socket, req: dict) -> None:
        t0 = time.perf_counter()
        shown_study = req.get("shown") or req.get("study")
        if req.get("source_sha256") != self.code or provenance.source_sha256() != self.code:
            self._reply(conn, {"err": f"monkeystudy: the server (pid {os.getpid()}) runs "
                                      "other monkeystudy code than this client (the package "
                                      "changed since it started): restart it with "
                                      "'monkeystudy serve'"}, EXIT_FAILED)
            self._say(f"refused {shown_study}: code changed since start")
            return
        alive = [True]

        def send(msg: dict) -> None:
            if alive[0]:
                try:
                    send_message(conn, msg)
                except OSError:
                    alive[0] = False

        try:
            loaded = load_study(req["study"], shown=shown_study)
        except StudyError as exc:
            send({"err": str(exc)})
            send({"exit": EXIT_INVALID})
            return
        cwd = Path(req.get("cwd") or ".")
        out = Path(req["out"]) if req.get("out") else cwd / default_out(loaded.study)
        if self.pool is None or not self.pool.usable:
            self.pool = local_pool(self.workers)

        finished = threading.Event()

        def watch() -> None:
            # the client half-closes (Ctrl-C) or goes away: stop the run in the main thread
            try:
                while conn.recv(1024):
                    pass
            except OSError:
                pass
            if not finished.is_set():
                os.kill(os.getpid(), signal.SIGUSR1)

        def shown(p: Path) -> str:
            try:
                return os.path.relpath(p, cwd) if Path(p).is_relative_to(cwd) else str(p)
            except ValueError:
                return str(p)

        threading.Thread(target=watch, name="monkeystudy-client-watch", daemon=True).start()
        try:
            code = execute_run(
                loaded, out, echo=lambda line: send({"out": line}),
                err=lambda line: send({"err": line}),
                reporter=lambda: PlainReporter(LineStream(send, "err"), every=2.0),
                command=req.get("command") or f"monkeystudy run {shown_study} --server",
                dry_run=bool(req.get("dry_run")), pool=self.pool, shown=shown,
                pause_after_blocks=pause_from_env(req.get("pause_after_blocks")))
        finally:
            finished.set()
        send({"exit": code})
        self._say(f"{shown_study} (from {cwd}): exit {code} in "
                  f"{time.perf_counter() - t0:.2f} s")


#: the study whose kernels the server loads before forking its workers (a run that needs
#: others loads them and re-forks the idle workers: see ``run_study(pool=...)``)
WARM_STUDY = """schema_version: 1
name: warm_up
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354}
steps:
  - {name: g, kind: grid, dtheta1: {start: 1.0, stop: 1.0, num: 1},
     dtheta2: {start: 11.0, stop: 11.0, num: 1}}
"""


__all__ = ["Server", "WARM_STUDY"]
