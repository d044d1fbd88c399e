"""The ``monkeystudy`` command line: run, serve, validate, schema, inspect, report, bench.

Exit codes: 0 done; 1 the run failed; 2 invalid input (a study file, an option, a missing
file); 3 interrupted or partial (finished blocks are saved: rerun to resume).

Built on click directly: its usage lines name arguments as they are written (``STUDY``), and
each command's one-line summary below is what ``monkeystudy --help`` lists, whole.
"""
from __future__ import annotations

import atexit
import gc
import json
import os
import signal
import sys
from pathlib import Path
from typing import Optional

import click

from . import __version__
from .exit_codes import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_INVALID

#: help text wider than click's default 80 columns where the terminal allows it
CONTEXT = {"help_option_names": ["-h", "--help"], "max_content_width": 100}


class _Commands(click.Group):
    """The command group: commands listed in the order they are declared, and a Ctrl-C that
    reaches a command (while it imports, loads or writes) ends it with exit code 3 and one
    line, never click's "Aborted!" (exit 1) or a traceback."""

    def list_commands(self, ctx):
        return list(self.commands)

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            _err(f"monkeystudy {ctx.invoked_subcommand or ''}: interrupted".replace(" :", ":"))
            raise click.exceptions.Exit(EXIT_INTERRUPTED) from None


@click.group(cls=_Commands, context_settings=CONTEXT, no_args_is_help=True,
             help="Batch gait studies of the MonkeyBot: YAML studies in, netCDF datasets out."
                  "\n\nExit codes: 0 done, 1 run failed, 2 invalid input, 3 interrupted or "
                  "partial (rerun to resume).")
@click.version_option(__version__, "--version", prog_name="monkeystudy",
                      message="%(prog)s %(version)s")
def app() -> None:
    pass


def _err(message: str) -> None:
    click.echo(message, err=True)


def _exit(code: int) -> None:
    if code:
        raise click.exceptions.Exit(code)


# Each command imports what it needs when it runs (the imports inside the functions below):
# --help, validate and the thin client of a served run start without numpy, numba or xarray.


#: what a study file is named
STUDY_SUFFIXES = (".yaml", ".yml")


def no_such_study(study: Path) -> str:
    """``<path>: no such file``, with the closest study files of its folder when some are
    close (``did you mean studies/horizontal.yaml?``)."""
    import difflib    # here: the message is all that needs it

    folder = study.parent
    names = sorted(p.name for p in folder.glob("*") if p.suffix in STUDY_SUFFIXES) \
        if folder.is_dir() else []
    close = difflib.get_close_matches(study.name, names, n=3, cutoff=0.75)
    hint = (f"; did you mean {' or '.join(str(folder / n) for n in close)}?" if close else "")
    return f"{study}: no such file{hint}"


def _study_exists(study: Path) -> None:
    """A missing study file ends the command at once (before the slow imports), with the
    closest names."""
    if not study.exists():
        _err(no_such_study(study))
        raise click.exceptions.Exit(EXIT_INVALID)


def _load(study: Path):
    from .study.loader import StudyError, load_study
    try:
        return load_study(study)
    except StudyError as exc:
        _err(str(exc))
        raise click.exceptions.Exit(EXIT_INVALID) from None


_SOCKET_HELP = ("the server's socket [default: $MONKEYSTUDY_SERVER or "
                "~/.cache/monkeystudy/serve.sock]")
_WORKERS_HELP = "local worker processes [default: all cores]"


@app.command(short_help="Run a study into netCDF datasets (resumes where it stopped).")
@click.argument("study", type=click.Path(path_type=Path), metavar="STUDY")
@click.option("-o", "--out", type=click.Path(path_type=Path), metavar="DIR",
              help="output folder [default: outputs/<study name>]")
@click.option("-j", "--workers", type=click.IntRange(min=1), metavar="N", help=_WORKERS_HELP)
@click.option("--scheduler", metavar="ADDRESS", help="Dask scheduler address, tcp://host:port")
@click.option("--dry-run", is_flag=True, help="list the steps and blocks to do; run nothing")
@click.option("--server", is_flag=True, help="hand the study to a resident 'monkeystudy serve'")
@click.option("--socket", "socket_path", metavar="PATH", help=_SOCKET_HELP)
def run(study: Path, out: Optional[Path], workers: Optional[int], scheduler: Optional[str],
        dry_run: bool, server: bool, socket_path: Optional[str]) -> None:
    """Run the study file STUDY: one netCDF dataset per step in the output folder. An
    interrupted run resumes where it stopped."""
    _study_exists(study)
    if server:
        _run_on_server(study, out, workers, scheduler, dry_run, socket_path)
        return
    if socket_path is not None:
        _err("--socket names the server of --server")
        raise click.exceptions.Exit(EXIT_INVALID)
    # Start-up allocates ~10^6 long-lived objects (numba's types, the loaded kernels): cyclic
    # collections while importing only rescan them (~0.2 s). The runner turns collection back
    # on once the kernels are loaded (and freezes them before it forks the workers).
    gc.disable()
    try:
        _run(study, out, workers, scheduler, dry_run)
    finally:
        gc.enable()


def _run(study: Path, out: Optional[Path], workers: Optional[int], scheduler: Optional[str],
         dry_run: bool) -> None:
    from .study.progress import ticking

    # said before the study's code loads (numba and the schema's models: 2 s on an idle
    # machine, more on a busy one), and ticking while it does
    _err(f"{study}: loading the simulator to check the study")
    with ticking(_err, "loading the simulator and checking the study"):
        from .service.client import sigterm_as_interrupt
        from .study.command import PAUSE_ENV, execute_run, pause_from_env
        from .study.progress import make_reporter
        from .study.provenance import run_command

        loaded = _load(study)
    if scheduler and workers is not None:
        _err("--workers applies to the local pool; with --scheduler the cluster decides")
        raise click.exceptions.Exit(EXIT_INVALID)
    previous = None if dry_run else sigterm_as_interrupt()
    try:
        code = execute_run(loaded, out, echo=click.echo, err=_err, reporter=make_reporter,
                           command=run_command(study, out, workers, scheduler), workers=workers,
                           scheduler=scheduler, dry_run=dry_run,
                           pause_after_blocks=pause_from_env(os.environ.get(PAUSE_ENV)))
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    _exit(code)


def _run_on_server(study: Path, out: Optional[Path], workers: Optional[int],
                   scheduler: Optional[str], dry_run: bool, socket_path: Optional[str]) -> None:
    """The thin client: no numpy, no numba; the server loads, validates and runs."""
    from .service.client import default_socket, submit_run
    from .study.provenance import run_command

    if workers is not None or scheduler:
        _err("--workers and --scheduler choose where a run goes: not with --server (the "
             "server's pool was chosen with 'monkeystudy serve --workers')")
        raise click.exceptions.Exit(EXIT_INVALID)
    path = socket_path or default_socket()
    _exit(submit_run(path, study, out, dry_run=dry_run,
                     command=run_command(study, out, None, None, path)))


@app.command(short_help="Keep the kernels loaded and a pool warm for 'run --server'.")
@click.option("--socket", "socket_path", metavar="PATH",
              help="the Unix socket to listen on [default: $MONKEYSTUDY_SERVER or "
                   "~/.cache/monkeystudy/serve.sock]")
@click.option("-j", "--workers", type=click.IntRange(min=1), metavar="N", help=_WORKERS_HELP)
@click.option("--stop", is_flag=True, help="stop the server listening there")
@click.option("--status", is_flag=True, help="is a server listening there?")
def serve(socket_path: Optional[str], workers: Optional[int], stop: bool, status: bool) -> None:
    """Keep the kernels loaded and a worker pool warm; 'monkeystudy run STUDY --server' hands
    studies to it."""
    from .service.client import ServiceError, default_socket, request
    from .study.progress import count

    path = socket_path or default_socket()
    if stop or status:
        try:
            msg = request(path, "stop" if stop else "ping")
        except (ServiceError, OSError, ValueError) as exc:
            _err(f"monkeystudy serve: {exc}")
            raise click.exceptions.Exit(EXIT_FAILED) from None
        state = "stopping" if stop else (
            f"{count(msg.get('workers') or 0, 'worker')}, monkeystudy {msg.get('version')}, "
            "sources "
            f"{msg.get('source_sha256', '')[:12]}")
        click.echo(f"server pid {msg.get('pid')} at {path}: {state}")
        return
    gc.disable()   # importing the server allocates ~10^6 long-lived objects: see run
    from .service.server import Server

    srv = Server(path, workers)
    try:
        srv.start()
    except (ServiceError, OSError) as exc:   # another server there; a bad socket path
        if srv.pool is not None:
            srv.close()
        _err(f"monkeystudy serve: {exc}")
        raise click.exceptions.Exit(EXIT_INVALID) from None
    except KeyboardInterrupt:
        srv.close()
        raise click.exceptions.Exit(EXIT_INTERRUPTED) from None
    srv.serve_forever()


@app.command(short_help="Check a study file without running it.")
@click.argument("study", type=click.Path(path_type=Path), metavar="STUDY")
def validate(study: Path) -> None:
    """Check the study file STUDY without running it: every problem, as file:line: key."""
    _study_exists(study)
    from .study.steps import kind_of
    loaded = _load(study)
    st = loaded.study
    blocks = sum(len(kind_of(s).blocks(s)) for s in st.steps)
    click.echo(f"{study}: ok - study {st.name!r}, {len(st.steps)} "
               f"step{'s' if len(st.steps) != 1 else ''} "
               f"({', '.join(f'{s.name} [{s.kind}]' for s in st.steps)}), "
               f"{blocks} resumable block{'s' if blocks != 1 else ''}")


@app.command(short_help="Print the JSON Schema of study files (for editors).")
def schema() -> None:
    """Print the JSON Schema of study files (for editors)."""
    from .study.schema import json_schema
    click.echo(json.dumps(json_schema(), indent=2))


@app.command(short_help="Summarise a dataset, or every dataset of a study folder.")
@click.argument("path", type=click.Path(path_type=Path), metavar="PATH")
def inspect(path: Path) -> None:
    """Summarise PATH: a dataset written by 'run' (.nc: provenance, variables, key numbers),
    or a study's output folder (the key numbers of each of its datasets)."""
    if path.is_file() and path.suffix in STUDY_SUFFIXES:
        _err(study_file_hint(path))
        raise click.exceptions.Exit(EXIT_INVALID)
    from .study.inspect import NoDatasets, summarize, summarize_folder
    try:
        if path.is_dir():
            text = summarize_folder(path)
        elif path.is_file():
            text = summarize(path)
        else:
            _err(f"{path}: no such file or folder")
            raise click.exceptions.Exit(EXIT_INVALID)
    except NoDatasets as exc:
        _err(str(exc))
        raise click.exceptions.Exit(EXIT_INVALID) from None
    except (OSError, ValueError) as exc:
        _err(f"{path}: cannot read as a netCDF dataset: {exc}")
        raise click.exceptions.Exit(EXIT_INVALID) from None
    click.echo(text)


def study_file_hint(path: Path) -> str:
    """What to do with a study file given to ``inspect``: validate it, or inspect the output
    folder its run writes (``outputs/<its name>``, read from its ``name:`` line)."""
    import re

    try:
        m = re.search(r"^name:\s*['\"]?([\w.-]+)", path.read_text(encoding="utf-8"), re.M)
    except (OSError, UnicodeDecodeError):
        m = None
    out = f"outputs/{m.group(1)}" if m else "outputs/<study name>"
    return (f"{path}: a study file, not a dataset: 'monkeystudy validate {path}' checks it; "
            f"'monkeystudy inspect {out}' summarises the datasets its run writes there")


#: still-figure formats ``report --formats`` takes
FIGURE_FORMATS = ("png", "pdf", "svg")


@app.command(short_help="Draw a study's figures and its page from its datasets.")
@click.argument("path", type=click.Path(path_type=Path), metavar="FOLDER")
@click.option("--force", is_flag=True, help="redraw every figure, even those up to date")
@click.option("--formats", default="png,pdf", show_default=True, metavar="LIST",
              help="still-figure formats, comma-separated: png, pdf, svg (png is always "
                   "drawn: the page shows it)")
@click.option("--no-animation", is_flag=True,
              help="skip the animations (the slowest figures)")
def report(path: Path, force: bool, formats: str, no_animation: bool) -> None:
    """Draw the figures of the study folder FOLDER (outputs/<name>) and its page,
    FOLDER/figures/index.html, from its datasets; only what changed is redrawn. The page lists
    every step of the study: exit code 1 if a step failed in the last run, 3 if a step has
    no dataset yet."""
    fmts = [f.strip().lower() for f in formats.split(",") if f.strip()]
    bad = [f for f in fmts if f not in FIGURE_FORMATS]
    if bad or not fmts:
        _err(f"--formats: {', '.join(bad) or 'nothing'} not among {', '.join(FIGURE_FORMATS)}")
        raise click.exceptions.Exit(EXIT_INVALID)
    if not path.is_dir():
        _err(f"{path}: no such folder")
        raise click.exceptions.Exit(EXIT_INVALID)
    # said before the plotting code loads (matplotlib, xarray: seconds on a busy machine)
    click.echo(f"{path}: reading its datasets to plan the figures")
    from .study.progress import ticking
    with ticking(click.echo, "loading the plotting code"):
        from .plotting.report import (
            FigureNameClash, NoStudyDatasets, ReportError, ReportInterrupted, StudyIncomplete,
            report_study,
        )
    try:
        report_study(path, force=force, formats=fmts, animation=not no_animation,
                     progress=click.echo)
    except ReportInterrupted as exc:
        _err(f"monkeystudy report: {exc}")
        raise click.exceptions.Exit(EXIT_INTERRUPTED) from None
    except (NoStudyDatasets, FigureNameClash) as exc:
        _err(f"monkeystudy report: {exc}")
        raise click.exceptions.Exit(EXIT_INVALID) from None
    except ReportError as exc:
        _err(f"monkeystudy report: {exc}")
        raise click.exceptions.Exit(EXIT_FAILED) from None
    except StudyIncomplete as exc:   # drawn and on the page; the study's run is not done
        _err(f"monkeystudy report: {exc}")
        raise click.exceptions.Exit(EXIT_FAILED if exc.failed else EXIT_INTERRUPTED) \
            from None
    except KeyboardInterrupt:
        raise
    except Exception as exc:  # the report code's failure is a failed run, not a crash
        _err(f"monkeystudy report: failed: {type(exc).__name__}: {exc}")
        raise click.exceptions.Exit(EXIT_FAILED) from None


@app.command(short_help="Benchmark the simulator against baselines timed in the same run.")
@click.option("--quick", is_flag=True, help="fewer points and repetitions")
@click.option("--startup", is_flag=True, help="also time cold and cached start-up")
@click.option("--workers", is_flag=True, help="also time 1 worker against all cores")
@click.option("--grid", type=int, multiple=True, metavar="N",
              help="also run an N-point error map end to end (repeatable)")
@click.option("--served", type=click.IntRange(min=0), default=0, show_default=True,
              metavar="K", help="with --grid: also time K runs of the same map handed to a "
                                "resident 'monkeystudy serve'")
def bench(quick: bool, startup: bool, workers: bool, grid: tuple[int, ...],
          served: int) -> None:
    """Benchmark the simulator: ratios to the bare right-hand side and to scipy, measured
    in one run."""
    from .bench import main as bench_main

    argv = [a for a, on in (("--quick", quick), ("--startup", startup), ("--workers", workers))
            if on] + [x for n in grid for x in ("--grid", str(n))] + \
        (["--served", str(served)] if served else [])
    _exit(bench_main(argv))


def main() -> None:  # pragma: no cover - the console script
    """The ``monkeystudy`` console script. At exit the heap is frozen first, so that the
    interpreter's final collection does not scan the ~10^6 objects of the loaded kernels
    (~0.2 s; everything is written, closed and renamed by then)."""
    atexit.register(gc.freeze)
    app(prog_name="monkeystudy")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
