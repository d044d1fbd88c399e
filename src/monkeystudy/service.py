"""A resident study service: ``monkeystudy serve`` keeps an interpreter with the kernels loaded
and a warm worker pool; ``monkeystudy run STUDY --server [--socket PATH]`` hands it the
study.

A run from the command line pays ~1 s before its first block: the interpreter, numpy, numba
(whose first dispatch imports scipy.linalg), the cached kernels, forking the pool. Against a
100,000-point map (1.5 s of simulation on two cores) that is most of the overhead. The service
pays it once; each run then costs its blocks, the consolidation, and ~0.1 s for the thin
client (which imports neither numpy nor numba).

The run itself is the command line's (:func:`monkeystudy.study.command.execute_run`, the same
:func:`~monkeystudy.study.runner.run_study`): same datasets, same resume, same exit codes. A
server runs one study at a time; another client waits for its turn.

Protocol (version :data:`PROTOCOL`): one JSON object per line over a Unix socket (a socket
file, mode 0600: only its owner can connect). The client sends one request::

    {"protocol": 1, "op": "run", "study": ABS, "shown": AS_TYPED, "cwd": CWD, "out": ABS|null,
     "dry_run": false, "command": "monkeystudy run ...", "source_sha256": HEX}
    {"protocol": 1, "op": "ping"} | {"protocol": 1, "op": "stop"}

and reads ``{"out": LINE}`` / ``{"err": LINE}`` until ``{"exit": CODE}`` (or, for ``ping``,
``{"pid": ..., "workers": ..., "source_sha256": ..., "version": ...}``). The client half-closes
its side on Ctrl-C: the server stops the run (finished blocks stay saved) and answers exit 3.

A server refuses a run when its code is not the client's (``source_sha256``, every source file of
the package): an edited package needs a restarted server, never a dataset computed by old code
under the new code's key.
"""
from __future__ import annotations

import json
import os
import signal
import socket
import sys
import time
from pathlib import Path
from typing import Callable, TextIO

PROTOCOL = 1
#: environment variable naming the server's socket (``serve --socket`` and ``run --socket``)
SERVER_ENV = "MONKEYSTUDY_SERVER"
from . import __version__
from .exit_codes import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_INVALID


def default_socket() -> str:
    """``$MONKEYSTUDY_SERVER``, else ``$XDG_CACHE_HOME/monkeystudy/serve.sock`` (by default
    ``~/.cache/monkeystudy/serve.sock``, next to the kernel cache)."""
    env = os.environ.get(SERVER_ENV)
    if env:
        return env
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(Path.home(), ".cache")
    return os.path.join(base, "monkeystudy", "serve.sock")


class ServiceError(RuntimeError):
    """No server, or it broke the protocol."""


def _connect(path: str, timeout: float | None = None) -> socket.socket:
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.settimeout(timeout)
    try:
        sock.connect(path)
    except (FileNotFoundError, ConnectionRefusedError) as exc:
        sock.close()
        raise ServiceError(f"no monkeystudy server at {path} ({exc.strerror}); start one with "
                           f"'monkeystudy serve --socket {path}'") from None
    except OSError as exc:
        sock.close()
        raise ServiceError(f"cannot connect to the monkeystudy server at {path}: {exc}") \
            from None
    return sock


class _Reader:
    """JSON messages read from a socket, one per line. Its buffer lives outside any generator,
    so a Ctrl-C that interrupts a read loses nothing: the client keeps reading afterwards
    (an exception raised inside a generator would finish it)."""

    def __init__(self, sock: socket.socket):
        self.sock, self.buf = sock, b""

    def next(self) -> dict | None:
        """The next message; None once the peer has closed."""
        while b"\n" not in self.buf:
            chunk = self.sock.recv(65536)
            if not chunk:
                return None
            self.buf += chunk
        line, self.buf = self.buf.split(b"\n", 1)
        return json.loads(line) if line.strip() else self.next()


def _send(sock: socket.socket, message: dict) -> None:
    sock.sendall(json.dumps(message).encode() + b"\n")


# --- the client (standard library only: it must start fast) ------------------------------------
def request(path: str, op: str, timeout: float | None = 10.0) -> dict:
    """One short request (``ping``, ``stop``) and its reply."""
    with _connect(path, timeout) as sock:
        _send(sock, {"protocol": PROTOCOL, "op": op})
        msg = _Reader(sock).next()
        if msg is not None:
            return msg
    raise ServiceError(f"the server at {path} closed the connection without answering")


def submit_run(path: str, study: Path, out: Path | None, *, command: str, dry_run: bool = False,
               stdout: TextIO | None = None, stderr: TextIO | None = None) -> int:
    """Run ``study`` on the server at ``path``, relaying its output; return the exit code.

    Ctrl-C (or SIGTERM) asks the server to stop the run and waits for its last words (exit
    3); a second one leaves at once."""
    from .study.provenance import source_sha256

    stdout = stdout or sys.stdout
    stderr = stderr or sys.stderr
    req = {"protocol": PROTOCOL, "op": "run", "study": os.path.abspath(study),
           "shown": str(study), "cwd": os.getcwd(),
           "out": os.path.abspath(out) if out is not None else None, "dry_run": dry_run,
           "command": command, "source_sha256": source_sha256()}
    try:
        sock = _connect(path)
    except ServiceError as exc:
        print(f"monkeystudy: {exc}", file=stderr, flush=True)
        return EXIT_FAILED
    previous = sigterm_as_interrupt()
    stopping = False
    try:
        _send(sock, req)
        messages = _Reader(sock)
        while True:
            try:
                msg = messages.next()
            except KeyboardInterrupt:
                if stopping:
                    print("monkeystudy: left without waiting for the server; finished blocks "
                          "are saved, rerun to resume", file=stderr, flush=True)
                    return EXIT_INTERRUPTED
                stopping = True
                print("monkeystudy: interrupted; asking the server to stop the run "
                      "(Ctrl-C again to leave now)", file=stderr, flush=True)
                sock.shutdown(socket.SHUT_WR)
                continue
            if msg is None:
                print(f"monkeystudy: the server at {path} closed the connection before the "
                      "run ended (it stopped or died); finished blocks are saved, rerun to "
                      "resume", file=stderr, flush=True)
                return EXIT_INTERRUPTED
            if "exit" in msg:
                return int(msg["exit"])
            for key, stream in (("out", stdout), ("err", stderr)):
                if key in msg:
                    print(msg[key], file=stream, flush=True)
    except (BrokenPipeError, ConnectionResetError):
        print(f"monkeystudy: lost the connection to the server at {path}; finished blocks "
              "are saved, rerun to resume", file=stderr, flush=True)
        return EXIT_INTERRUPTED
    finally:
        sock.close()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def sigterm_as_interrupt():
    """SIGTERM stops like Ctrl-C (finished blocks are kept); returns the previous handler, or
    None off the main thread (where no handler can be set)."""
    def handler(signum, frame):
        raise KeyboardInterrupt
    try:
        return signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread
        return None


# --- the server ----------------------------------------------------------------------------------
class _ClientGone(KeyboardInterrupt):
    """The client of the current run half-closed or closed its connection."""


class _Stop(KeyboardInterrupt):
    """SIGINT or SIGTERM to the server: stop the run and the server."""


class _Lines:
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

    def _say(self, text: str) -> None:
        print(f"[monkeystudy serve] {text}", file=self.log, flush=True)

    def start(self) -> None:
        import gc
        gc.disable()   # start-up allocates ~10^6 long-lived objects: see cli.run
        try:
            self._check_free()
            from .study import analysis_tasks, drivers, provenance
            from .study.loader import parse_study
            from .study.runner import local_pool, study_spec

            self.code = provenance.source_sha256()
            provenance.code_sha256()        # pinned (cached) with the code it describes
            provenance.git_revision()       # pinned too: the datasets' provenance attrs
            provenance.library_versions()
            t0 = time.perf_counter()
            spec = study_spec(parse_study(_WARM_STUDY, "<warm-up>").study)
            drivers.warm_up(spec, stability=True)
            analysis_tasks.warm_up(spec)
            self._say(f"kernels loaded in {time.perf_counter() - t0:.1f} s")
            self.pool = local_pool(self.workers)   # forked now: the workers inherit it all
        finally:
            gc.enable()
        self._bind()
        self._say(f"pid {os.getpid()}, {self.pool.slots} worker(s), listening on {self.path} "
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
            raise _Stop

        def client_gone(signum, frame):
            raise _ClientGone

        previous = {s: signal.signal(s, h) for s, h in ((signal.SIGINT, stop),
                                                         (signal.SIGTERM, stop),
                                                         (signal.SIGUSR1, client_gone))}
        try:
            while not self._stop:
                try:
                    conn, _ = self.sock.accept()
                except _ClientGone:       # a late signal from a finished run's watcher
                    continue
                except _Stop:
                    break
                with conn:
                    try:
                        self._handle(conn)
                    except _ClientGone:
                        pass
                    except _Stop:
                        break
                    except Exception as exc:  # a bug: tell the client, keep serving
                        import traceback
                        text = "".join(traceback.format_exception(exc))
                        self._say(f"request failed:\n{text}")
                        self._reply(conn, {"err": f"monkeystudy serve: request failed: "
                                                  f"{type(exc).__name__}: {exc}"}, EXIT_FAILED)
        finally:
            for s, h in previous.items():
                signal.signal(s, h)
            self.close()

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
            self.sock = None
            try:
                os.unlink(self.path)
            except FileNotFoundError:
                pass
        if self.pool is not None:
            self.pool.abort()
            self.pool = None
        self._say("stopped")

    # one connection -------------------------------------------------------------------------
    def _handle(self, conn: socket.socket) -> None:
        conn.settimeout(10.0)
        try:
            req = _Reader(conn).next()
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
            _send(conn, {"pid": os.getpid(), "workers": self.pool.slots if self.pool else 0,
                         "source_sha256": self.code, "version": __version__})
        elif op == "stop":
            _send(conn, {"pid": os.getpid(), "stopping": True})
            self._stop = True
        elif op == "run":
            self._run(conn, req)
        else:
            self._reply(conn, {"err": f"unknown request {op!r}"}, EXIT_INVALID)

    def _reply(self, conn, message: dict | None, code: int) -> None:
        try:
            if message is not None:
                _send(conn, message)
            _send(conn, {"exit": code})
        except OSError:
            pass

    def _run(self, conn: socket.socket, req: dict) -> None:
        import threading

        from .study import provenance
        from .study.command import execute_run
        from .study.loader import StudyError, load_study
        from .study.progress import PlainReporter
        from .study.runner import default_out, local_pool

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
                    _send(conn, msg)
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
                reporter=lambda: PlainReporter(_Lines(send, "err"), every=2.0),
                command=req.get("command") or f"monkeystudy run {shown_study} --server",
                dry_run=bool(req.get("dry_run")), pool=self.pool, shown=shown)
        finally:
            finished.set()
        send({"exit": code})
        self._say(f"{shown_study} (from {cwd}): exit {code} in "
                  f"{time.perf_counter() - t0:.2f} s")


#: the study whose kernels the server loads before forking its workers (a run that needs
#: others loads them and re-forks the idle workers: see runner._resident)
_WARM_STUDY = """schema_version: 1
name: warm_up
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354}
steps:
  - {name: g, kind: grid, dtheta1: {start: 1.0, stop: 1.0, num: 1},
     dtheta2: {start: 11.0, stop: 11.0, num: 1}}
"""


__all__ = ["PROTOCOL", "SERVER_ENV", "Server", "ServiceError", "default_socket", "request",
           "submit_run"]
