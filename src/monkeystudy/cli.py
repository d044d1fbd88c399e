"""The ``monkeystudy`` command line: run, validate, inspect, schema, report.

Exit codes: 0 done; 1 the run failed; 2 invalid input (a study file, an option, a missing
file); 3 interrupted or partial (finished blocks are saved: rerun to resume).
"""
from __future__ import annotations

import atexit
import gc
import json
import signal
import traceback
from pathlib import Path
from typing import Optional

import typer

EXIT_OK, EXIT_FAILED, EXIT_INVALID, EXIT_INTERRUPTED = 0, 1, 2, 3

app = typer.Typer(
    name="monkeystudy", add_completion=False, no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Batch gait studies of the MonkeyBot: YAML studies in, netCDF datasets out.\n\n"
         "Exit codes: 0 done, 1 run failed, 2 invalid input, 3 interrupted/partial "
         "(rerun resumes).",
)


def _err(message: str) -> None:
    typer.echo(message, err=True)


def _load(study: Path):
    from .study.loader import StudyError, load_study
    try:
        return load_study(study)
    except StudyError as exc:
        _err(str(exc))
        raise typer.Exit(EXIT_INVALID) from None


def _sigterm_as_interrupt():
    """SIGTERM stops a run like Ctrl-C (finished blocks are kept)."""
    def handler(signum, frame):
        raise KeyboardInterrupt
    try:
        return signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread
        return None


@app.command()
def run(
    study: Path = typer.Argument(..., help="study file (YAML)", show_default=False),
    out: Optional[Path] = typer.Option(None, "--out", "-o",
                                       help="output folder [default: outputs/<study name>]"),
    workers: Optional[int] = typer.Option(None, "--workers", "-j", min=1,
                                          help="local worker processes [default: all cores]"),
    scheduler: Optional[str] = typer.Option(None, "--scheduler",
                                            help="Dask scheduler address, tcp://host:port"),
    dry_run: bool = typer.Option(False, "--dry-run",
                                 help="list the steps and blocks to do; run nothing"),
) -> None:
    """Run a study: one netCDF dataset per step in the output folder; resumes."""
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
    from .study.progress import make_reporter
    from .study.runner import RunFailed, RunInterrupted, plan_study, run_study

    loaded = _load(study)
    if scheduler and workers is not None:
        _err("--workers applies to the local pool; with --scheduler the cluster decides")
        raise typer.Exit(EXIT_INVALID)
    if dry_run:
        plan = plan_study(loaded, out)
        typer.echo(plan.describe())
        typer.echo("dry run: nothing was run" if not plan.up_to_date
                   else "dry run: everything is up to date")
        return
    reporter = make_reporter()
    previous = _sigterm_as_interrupt()
    command = " ".join(["monkeystudy", "run", str(study)]
                       + ([f"--out {out}"] if out is not None else [])
                       + ([f"--workers {workers}"] if workers is not None else [])
                       + ([f"--scheduler {scheduler}"] if scheduler else []))
    try:
        summary = run_study(loaded, out, workers=workers, scheduler=scheduler,
                            reporter=reporter, command=command)
    except RunInterrupted as exc:
        reporter.close()
        _err(f"monkeystudy: {exc}")
        raise typer.Exit(EXIT_INTERRUPTED) from None
    except RunFailed as exc:
        reporter.close()
        _err(f"monkeystudy: run failed: {exc}")
        raise typer.Exit(EXIT_FAILED) from None
    except Exception as exc:  # a bug or an environment problem: say so, keep the traceback
        reporter.close()
        _err("".join(traceback.format_exception(exc)))
        _err(f"monkeystudy: run failed: {type(exc).__name__}: {exc} (finished blocks are "
             "saved)")
        raise typer.Exit(EXIT_FAILED) from None
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    reporter.close()
    for p in summary.written:
        typer.echo(f"wrote {p}")
    for p in summary.up_to_date:
        typer.echo(f"up to date {p}")


@app.command()
def validate(study: Path = typer.Argument(..., help="study file (YAML)",
                                          show_default=False)) -> None:
    """Check a study file (every problem, with file:line: key) without running it."""
    from .study.schema import GridStep
    loaded = _load(study)
    st = loaded.study
    blocks = sum(s.n_blocks for s in st.steps if isinstance(s, GridStep))
    typer.echo(f"{study}: ok - study {st.name!r}, {len(st.steps)} steps "
               f"({', '.join(f'{s.name} [{s.kind}]' for s in st.steps)}), "
               f"{blocks} grid blocks")


@app.command()
def schema() -> None:
    """Print the JSON Schema of study files (for editors)."""
    from .study.schema import json_schema
    typer.echo(json.dumps(json_schema(), indent=2))


@app.command()
def inspect(path: Path = typer.Argument(..., help="a dataset written by 'run' (.nc)",
                                        show_default=False)) -> None:
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


@app.command()
def report(path: Path = typer.Argument(..., help="a study output folder (outputs/<name>)",
                                       show_default=False)) -> None:
    """Make the figures of a study's datasets (monkeystudy.plotting.report)."""
    if not path.is_dir():
        _err(f"{path}: no such folder")
        raise typer.Exit(EXIT_INVALID)
    try:
        from .plotting.report import report_study
    except ImportError as exc:
        _err("monkeystudy report: the figure code is not available "
             f"(monkeystudy.plotting.report.report_study cannot be imported: {exc})")
        raise typer.Exit(EXIT_FAILED) from None
    try:
        made = report_study(path)
    except Exception as exc:  # the report code's failure is a failed run, not a crash
        _err(f"monkeystudy report: failed: {type(exc).__name__}: {exc}")
        raise typer.Exit(EXIT_FAILED) from None
    for p in made or []:
        typer.echo(f"wrote {p}")


@app.command(context_settings={"allow_extra_args": True, "ignore_unknown_options": True})
def bench(ctx: typer.Context,
          quick: bool = typer.Option(False, "--quick", help="fewer points and repetitions"),
          startup: bool = typer.Option(False, "--startup",
                                       help="also time cold and cached start-up"),
          workers: bool = typer.Option(False, "--workers",
                                       help="also time 1 worker against all cores")) -> None:
    """Benchmark the simulator: ratios to the bare RHS and to scipy, measured in one run."""
    from .bench import main as bench_main

    argv = [a for a, on in (("--quick", quick), ("--startup", startup), ("--workers", workers))
            if on]
    raise typer.Exit(bench_main(argv + list(ctx.args)))


def main() -> None:  # pragma: no cover - the console script
    """The ``monkeystudy`` console script. At exit the heap is frozen first, so that the
    interpreter's final collection does not scan the ~10^6 objects of the loaded kernels
    (~0.2 s; everything is written, closed and renamed by then)."""
    atexit.register(gc.freeze)
    app()


if __name__ == "__main__":  # pragma: no cover
    main()
