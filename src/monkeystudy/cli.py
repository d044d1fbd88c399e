"""The ``monkeystudy`` command line: run, validate, inspect, schema, report.

Exit codes: 0 done; 1 the run failed; 2 invalid input (a study file, an option, a missing
file); 3 interrupted or partial (finished blocks are saved: rerun to resume).
"""
from __future__ import annotations

import atexit
import gc
import json
import signal
from pathlib import Path
from typing import Optional

import typer

from .exit_codes import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_INVALID

app = typer.Typer(
    name="monkeystudy", add_completion=False, no_args_is_help=True,
    pretty_exceptions_enable=False, rich_markup_mode=None,
    help="Batch gait studies of the MonkeyBot: YAML studies in, netCDF datasets out.\n\n"
         "Exit codes: 0 done, 1 run failed, 2 invalid input, 3 interrupted/partial "
         "(rerun resumes).",
)


def _err(message: str) -> None:
    typer.echo(message, err=True)


# Each command imports what it needs when it runs (the imports inside the functions below):
# --help, validate and the thin client of a served run start without numpy, numba or xarray.


def _load(study: Path):
    from .study.loader import StudyError, load_study
    try:
        return load_study(study)
    except StudyError as exc:
        _err(str(exc))
        raise typer.Exit(EXIT_INVALID) from None


@app.command()
def run(
    study: Path = typer.Argument(..., help="study file (YAML)", show_default=False,
                                 metavar="STUDY"),
    out: Optional[Path] = typer.Option(None, "--out", "-o", metavar="DIR",
                                       help="output folder [default: outputs/<study name>]"),
    workers: Optional[int] = typer.Option(None, "--workers", "-j", min=1, metavar="N",
                                          help="local worker processes [default: all cores]"),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", metavar="ADDRESS",
                                            help="Dask scheduler address, tcp://host:port"),
    dry_run: bool = typer.Option(False, "--dry-run",
                                 help="list the steps and blocks to do; run nothing"),
    server: bool = typer.Option(False, "--server",
                                help="hand the study to a resident 'monkeystudy serve'"),
    socket_path: Optional[str] = typer.Option(
        None, "--socket", metavar="PATH",
        help="the server's socket [default: $MONKEYSTUDY_SERVER or "
             "~/.cache/monkeystudy/serve.sock]"),
) -> None:
    """Run a study: one netCDF dataset per step in the output folder; resumes."""
    if server:
        _run_on_server(study, out, workers, scheduler, dry_run, socket_path)
        return
    if socket_path is not None:
        _err("--socket names the server of --server")
        raise typer.Exit(EXIT_INVALID)
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
    from .service.client import sigterm_as_interrupt
    from .study.command import execute_run
    from .study.progress import make_reporter
    from .study.provenance import run_command

    loaded = _load(study)
    if scheduler and workers is not None:
        _err("--workers applies to the local pool; with --scheduler the cluster decides")
        raise typer.Exit(EXIT_INVALID)
    previous = None if dry_run else sigterm_as_interrupt()
    try:
        code = execute_run(loaded, out, echo=typer.echo, err=_err, reporter=make_reporter,
                           command=run_command(study, out, workers, scheduler), workers=workers,
                           scheduler=scheduler, dry_run=dry_run)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    if code:
        raise typer.Exit(code)


def _run_on_server(study: Path, out: Optional[Path], workers: Optional[int],
                   scheduler: Optional[str], dry_run: bool, socket_path: Optional[str]) -> None:
    """The thin client: no numpy, no numba; the server loads, validates and runs."""
    from .service.client import default_socket, submit_run
    from .study.provenance import run_command

    if workers is not None or scheduler:
        _err("--workers and --scheduler choose where a run goes: not with --server (the "
             "server's pool was chosen with 'monkeystudy serve --workers')")
        raise typer.Exit(EXIT_INVALID)
    path = socket_path or default_socket()
    code = submit_run(path, study, out, dry_run=dry_run,
                      command=run_command(study, out, None, None, path))
    if code:
        raise typer.Exit(code)


@app.command()
def serve(
    socket_path: Optional[str] = typer.Option(
        None, "--socket", metavar="PATH",
        help="the Unix socket to listen on [default: $MONKEYSTUDY_SERVER or "
             "~/.cache/monkeystudy/serve.sock]"),
    workers: Optional[int] = typer.Option(None, "--workers", "-j", min=1, metavar="N",
                                          help="local worker processes [default: all cores]"),
    stop: bool = typer.Option(False, "--stop", help="stop the server listening there"),
    status: bool = typer.Option(False, "--status", help="is a server listening there?"),
) -> None:
    """Keep the kernels loaded and a worker pool warm; 'run --server' hands studies to it."""
    from .service.client import ServiceError, default_socket, request

    path = socket_path or default_socket()
    if stop or status:
        try:
            msg = request(path, "stop" if stop else "ping")
        except (ServiceError, OSError, ValueError) as exc:
            _err(f"monkeystudy serve: {exc}")
            raise typer.Exit(EXIT_FAILED) from None
        state = "stopping" if stop else (
            f"{msg.get('workers')} worker(s), monkeystudy {msg.get('version')}, sources "
            f"{msg.get('source_sha256', '')[:12]}")
        typer.echo(f"server pid {msg.get('pid')} at {path}: {state}")
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
        raise typer.Exit(EXIT_INVALID) from None
    except KeyboardInterrupt:
        srv.close()
        raise typer.Exit(EXIT_INTERRUPTED) from None
    srv.serve_forever()


@app.command()
def validate(study: Path = typer.Argument(..., help="study file (YAML)", show_default=False,
                                          metavar="STUDY")) -> None:
    """Check a study file (every problem, with file:line: key) without running it."""
    from .study.steps import kind_of
    loaded = _load(study)
    st = loaded.study
    blocks = sum(len(kind_of(s).blocks(s)) for s in st.steps)
    typer.echo(f"{study}: ok - study {st.name!r}, {len(st.steps)} steps "
               f"({', '.join(f'{s.name} [{s.kind}]' for s in st.steps)}), "
               f"{blocks} resumable blocks")


@app.command()
def schema() -> None:
    """Print the JSON Schema of study files (for editors)."""
    from .study.schema import json_schema
    typer.echo(json.dumps(json_schema(), indent=2))


@app.command()
def inspect(path: Path = typer.Argument(..., help="a dataset written by 'run' (.nc)",
                                        show_default=False, metavar="DATASET")) -> None:
    """Print a readable summary of a dataset."""
    from .study.inspect import summarize
    if not path.is_file():
        _err(f"{path}: no such file")
        raise typer.Exit(EXIT_INVALID)
    try:
        text = summarize(path)
    except (OSError, ValueError) as exc:
        _err(f"{path}: cannot read as a netCDF dataset: {exc}")
        raise typer.Exit(EXIT_INVALID) from None
    typer.echo(text)


#: still-figure formats ``report --formats`` takes
FIGURE_FORMATS = ("png", "pdf", "svg")


@app.command()
def report(
    path: Path = typer.Argument(..., help="a study's output folder (outputs/<name>)",
                                show_default=False, metavar="FOLDER"),
    force: bool = typer.Option(False, "--force", help="redraw every figure, even those up "
                                                       "to date"),
    formats: str = typer.Option("png,pdf", "--formats", metavar="LIST",
                                help="still-figure formats, comma-separated: png, pdf, svg "
                                     "(png is always drawn: the page shows it)"),
    no_animation: bool = typer.Option(False, "--no-animation",
                                      help="skip the animations (the slowest figures)"),
) -> None:
    """Draw a study's figures and its page (figures/index.html) from its datasets."""
    fmts = [f.strip().lower() for f in formats.split(",") if f.strip()]
    bad = [f for f in fmts if f not in FIGURE_FORMATS]
    if bad or not fmts:
        _err(f"--formats: {', '.join(bad) or 'nothing'} not among {', '.join(FIGURE_FORMATS)}")
        raise typer.Exit(EXIT_INVALID)
    if not path.is_dir():
        _err(f"{path}: no such folder")
        raise typer.Exit(EXIT_INVALID)
    from .plotting.report import NoStudyDatasets, ReportError, ReportInterrupted, report_study
    try:
        report_study(path, force=force, formats=fmts, animation=not no_animation,
                     progress=typer.echo)
    except ReportInterrupted as exc:
        _err(f"monkeystudy report: {exc}")
        raise typer.Exit(EXIT_INTERRUPTED) from None
    except NoStudyDatasets as exc:
        _err(f"monkeystudy report: {exc}")
        raise typer.Exit(EXIT_INVALID) from None
    except ReportError as exc:
        _err(f"monkeystudy report: {exc}")
        raise typer.Exit(EXIT_FAILED) from None
    except Exception as exc:  # the report code's failure is a failed run, not a crash
        _err(f"monkeystudy report: failed: {type(exc).__name__}: {exc}")
        raise typer.Exit(EXIT_FAILED) from None


@app.command()
def bench(quick: bool = typer.Option(False, "--quick", help="fewer points and repetitions"),
          startup: bool = typer.Option(False, "--startup",
                                       help="also time cold and cached start-up"),
          workers: bool = typer.Option(False, "--workers",
                                       help="also time 1 worker against all cores"),
          grid: Optional[list[int]] = typer.Option(
              None, "--grid", metavar="N", help="also run an N-point error map end to end "
                                                "(repeatable)"),
          served: int = typer.Option(0, "--served", metavar="K", min=0,
                                     help="with --grid: also time K runs of the same map "
                                          "handed to a resident 'monkeystudy serve'")) -> None:
    """Benchmark the simulator: ratios to the bare RHS and to scipy, measured in one run."""
    from .bench import main as bench_main

    argv = [a for a, on in (("--quick", quick), ("--startup", startup), ("--workers", workers))
            if on] + [x for n in grid or [] for x in ("--grid", str(n))] + \
        (["--served", str(served)] if served else [])
    raise typer.Exit(bench_main(argv))


def main() -> None:  # pragma: no cover - the console script
    """The ``monkeystudy`` console script. At exit the heap is frozen first, so that the
    interpreter's final collection does not scan the ~10^6 objects of the loaded kernels
    (~0.2 s; everything is written, closed and renamed by then)."""
    atexit.register(gc.freeze)
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
