"""How a run can fail: the exceptions the command line maps to exit codes 1 and 3."""
from __future__ import annotations


class RunFailed(RuntimeError):
    """A task raised, a step found nothing to work on, or a result could not be written
    (exit code 1)."""


class RunInterrupted(RuntimeError):
    """The run stopped early (Ctrl-C, SIGTERM, a dead worker); finished blocks are saved and a
    rerun resumes (exit code 3)."""
