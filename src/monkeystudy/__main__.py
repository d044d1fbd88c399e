"""The ``monkeystudy`` console script (also ``python -m monkeystudy``).

``monkeystudy run STUDY --server`` is the thin client of a resident ``monkeystudy serve``: its
whole job is to send the study's path and relay the answer, so it takes a short path that
imports neither the command-line framework nor numpy or numba. Everything else, and any
served run whose arguments this parser does not take cleanly (help, mistakes, ``--workers``),
goes to :mod:`monkeystudy.cli`, which reports it. ``tests/test_service.py`` keeps the two
parsers' options equal. A Ctrl-C before a command has started (while Python imports it) ends
with exit code 3 and one line, as one during the command does.
"""
from __future__ import annotations

import argparse
import sys


class _Refused(Exception):
    """Arguments this path does not take: the full command line handles (and reports) them."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # argparse would print usage and exit
        raise _Refused(message)


def served_run_parser() -> argparse.ArgumentParser:
    """``run``'s options, as :func:`monkeystudy.cli.run` declares them."""
    ap = _Parser(prog="monkeystudy run", add_help=False)
    ap.add_argument("study")
    ap.add_argument("--out", "-o")
    ap.add_argument("--workers", "-j", type=int)
    ap.add_argument("--scheduler")
    ap.add_argument("--dry-run", action="store_true")
    ap.add_argument("--server", action="store_true")
    ap.add_argument("--socket")
    return ap


def _served_run(argv: list[str]) -> int | None:
    """The exit code of a served run, or None when ``argv`` is not one this path takes."""
    if len(argv) < 2 or argv[0] != "run" or "--server" not in argv[1:]:
        return None
    if any(a in ("-h", "--help") for a in argv[1:]):
        return None
    try:
        args = served_run_parser().parse_args(argv[1:])
    except _Refused:
        return None
    if args.workers is not None or args.scheduler:
        return None
    from pathlib import Path

    from .service.client import default_socket, submit_run
    from .study.provenance import run_command
    path = args.socket or default_socket()
    study = Path(args.study)
    out = Path(args.out) if args.out is not None else None
    return submit_run(path, study, out, dry_run=args.dry_run,
                      command=run_command(study, out, None, None, path))


def main() -> None:  # pragma: no cover - the console script
    from .exit_codes import EXIT_INTERRUPTED
    try:
        code = _served_run(sys.argv[1:])
    except KeyboardInterrupt:   # the served run handles its own; this is before or after it
        print("monkeystudy: interrupted", file=sys.stderr)
        sys.exit(EXIT_INTERRUPTED)
    if code is not None:
        sys.exit(code)
    try:
        from .cli import main as cli_main
    except KeyboardInterrupt:
        print("monkeystudy: interrupted before the command started; nothing was written",
              file=sys.stderr)
        sys.exit(EXIT_INTERRUPTED)
    cli_main()


if __name__ == "__main__":  # pragma: no cover
    main()
