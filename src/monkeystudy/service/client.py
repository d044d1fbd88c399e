"""The client side of ``monkeystudy serve``, and the protocol's pieces both sides use.

Standard library only: ``monkeystudy run STUDY --server`` starts in ~0.1 s because it imports
neither numpy nor numba (an import contract in ``pyproject.toml`` keeps it so).
"""
from __future__ import annotations

import json
import os
import signal
import socket
import sys
from pathlib import Path
from typing import TextIO

from ..exit_codes import EXIT_FAILED, EXIT_INTERRUPTED
from ..study import provenance

#: version of the protocol (one JSON object per line, see :mod:`monkeystudy.service`)
PROTOCOL = 1
#: environment variable naming the server's socket (``serve --socket`` and ``run --socket``)
SERVER_ENV = "MONKEYSTUDY_SERVER"


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


def connect(path: str, timeout: float | None = None) -> socket.socket:
    """A connected Unix socket to the server at ``path`` (:class:`ServiceError`: none)."""
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


class MessageReader:
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


def send_message(sock: socket.socket, message: dict) -> None:
    """One message: JSON on one line."""
    sock.sendall(json.dumps(message).encode() + b"\n")


def request(path: str, op: str, timeout: float | None = 10.0) -> dict:
    """One short request (``ping``, ``stop``) and its reply."""
    with connect(path, timeout) as sock:
        send_message(sock, {"protocol": PROTOCOL, "op": op})
        msg = MessageReader(sock).next()
        if msg is not None:
            return msg
    raise ServiceError(f"the server at {path} closed the connection without answering")


def submit_run(path: str, study: Path, out: Path | None, *, command: str, dry_run: bool = False,
               stdout: TextIO | None = None, stderr: TextIO | None = None) -> int:
    """Run ``study`` on the server at ``path``, relaying its output; return the exit code.

    Ctrl-C (or SIGTERM) asks the server to stop the run and waits for its last words (exit
    3); a second one leaves at once."""
    stdout = stdout or sys.stdout
    stderr = stderr or sys.stderr
    req = {"protocol": PROTOCOL, "op": "run", "study": os.path.abspath(study),
           "shown": str(study), "cwd": os.getcwd(),
           "out": os.path.abspath(out) if out is not None else None, "dry_run": dry_run,
           "command": command, "source_sha256": provenance.source_sha256(),
           # for testing interruptions at a known point (monkeystudy.study.command.PAUSE_ENV)
           "pause_after_blocks": os.environ.get("MONKEYSTUDY_PAUSE_AFTER_BLOCKS")}
    try:
        sock = connect(path)
    except ServiceError as exc:
        print(f"monkeystudy: {exc}", file=stderr, flush=True)
        return EXIT_FAILED
    previous = sigterm_as_interrupt()
    stopping = False
    try:
        send_message(sock, req)
        messages = MessageReader(sock)
        while True:
            # a signal may land while a line is relayed as well as while one is awaited
            try:
                msg = messages.next()
                if msg is None:
                    print(f"monkeystudy: the server at {path} closed the connection before "
                          "the run ended (it stopped or died); finished blocks are saved, "
                          "rerun to resume", file=stderr, flush=True)
                    return EXIT_INTERRUPTED
                if "exit" in msg:
                    return int(msg["exit"])
                for key, stream in (("out", stdout), ("err", stderr)):
                    if key in msg:
                        print(msg[key], file=stream, flush=True)
            except KeyboardInterrupt:
                if stopping:
                    print("monkeystudy: left without waiting for the server; finished blocks "
                          "are saved, rerun to resume", file=stderr, flush=True)
                    return EXIT_INTERRUPTED
                stopping = True
                print("monkeystudy: interrupted; asking the server to stop the run "
                      "(Ctrl-C again to leave now)", file=stderr, flush=True)
                sock.shutdown(socket.SHUT_WR)
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


__all__ = ["MessageReader", "PROTOCOL", "SERVER_ENV", "ServiceError", "connect",
           "default_socket", "request", "send_message", "sigterm_as_interrupt", "submit_run"]
