"""What ``monkeystudy run`` does once the study is loaded, shared by the command line and by
``monkeystudy serve`` (which runs it for a client on its resident pool).

Output goes through two callables, ``echo`` (results: standard output) and ``err`` (messages:
standard error), and the outcome is an exit code:

0 done; 1 the run failed (a step failed: every step that did not depend on it ran); 2 invalid
input; 3 interrupted or partial (rerun to resume).
"""
from __future__ import annotations

import traceback
from pathlib import Path
from typing import Callable

from .errors import RunFailed, RunInterrupted
from .loader import LoadedStudy
from .plan import plan_study
from .progress import Reporter
from .runner import RunSummary, StepsFailed, run_study

from ..exit_codes import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_INVALID, EXIT_OK


def execute_run(loaded: LoadedStudy, out: Path | None, *, echo: Callable[[str], None],
                err: Callable[[str], None], reporter: Callable[[], Reporter],
                command: str, workers: int | None = None, scheduler: str | None = None,
                dry_run: bool = False, pool=None, shown: Callable[[Path], str] = str,
                pause_after_blocks: int | None = None) -> int:
    """Run (or with ``dry_run`` describe) ``loaded`` into ``out``; return the exit code.

    ``reporter`` makes the progress reporter (only when there is something to run);
    ``pool`` is a resident :class:`~.pool.Pool`; ``shown`` renders written paths;
    ``pause_after_blocks``: see :func:`~.runner.run_study` (for testing interruptions).
    """
    if dry_run:
        plan = plan_study(loaded, out)
        echo(plan.describe())
        echo("dry run: nothing was run" if not plan.up_to_date
             else "dry run: everything is up to date")
        return EXIT_OK
    rep = reporter()
    try:
        summary = run_study(loaded, out, workers=workers, scheduler=scheduler, reporter=rep,
                            command=command, pool=pool, pause_after_blocks=pause_after_blocks)
    except RunInterrupted as exc:
        rep.close()
        err(f"monkeystudy: {exc}")
        return EXIT_INTERRUPTED
    except StepsFailed as exc:      # the other steps ran: say what they wrote
        rep.close()
        _written(exc.summary, echo, shown)
        err(f"monkeystudy: run failed: {exc}")
        err("(each step that failed or was not run left <step>.failed.json in "
            f"{shown(exc.summary.out)}; 'monkeystudy report' lists them)")
        return EXIT_FAILED
    except RunFailed as exc:
        rep.close()
        err(f"monkeystudy: run failed: {exc}")
        return EXIT_FAILED
    except Exception as exc:  # a bug or an environment problem: say so, keep the traceback
        rep.close()
        err("".join(traceback.format_exception(exc)))
        err(f"monkeystudy: run failed: {type(exc).__name__}: {exc} (finished blocks are "
            "saved)")
        return EXIT_FAILED
    rep.close()
    _written(summary, echo, shown)
    return EXIT_OK


def _written(summary: RunSummary, echo: Callable[[str], None], shown: Callable[[Path], str]):
    for p in summary.written:
        echo(f"wrote {shown(p)}")
    for p in summary.up_to_date:
        echo(f"up to date {shown(p)}")


#: environment variable that pauses a run after so many computed blocks (for testing
#: interruptions at a known point; read by the command line and sent to a server)
PAUSE_ENV = "MONKEYSTUDY_PAUSE_AFTER_BLOCKS"


def pause_from_env(value: str | None) -> int | None:
    """``$MONKEYSTUDY_PAUSE_AFTER_BLOCKS`` as a count (None: unset or not a number >= 0)."""
    try:
        n = int(value) if value else None
    except ValueError:
        return None
    return n if n is not None and n >= 0 else None


__all__ = ["EXIT_FAILED", "EXIT_INTERRUPTED", "EXIT_INVALID", "EXIT_OK", "PAUSE_ENV", "execute_run", "pause_from_env"]
