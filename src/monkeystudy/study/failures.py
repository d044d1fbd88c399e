"""Failure markers: what a run leaves for a step that wrote no dataset.

A step whose run failed (a task raised, the step found nothing to work on, its dataset could
not be written) leaves ``<out>/<step>.failed.json`` with the reason, and so does each step
not run because a step it depends on failed. A marker is written atomically (a temporary
file, fsync, rename) the moment the failure is known, whatever ends the run after it. A run
removes the markers of its folder when it starts, so the markers of a folder are always those
of its last run; ``monkeystudy report`` lists every step of the study with them.
"""
from __future__ import annotations

import json
import os
import uuid
from dataclasses import asdict, dataclass
from datetime import datetime, timezone
from pathlib import Path

#: a marker's file name after the step's name
MARKER_SUFFIX = ".failed.json"

#: what became of a step that has a marker
FAILED, NOT_RUN = "failed", "not_run"


@dataclass(frozen=True)
class StepFailure:
    """Why a step of a run wrote no dataset.

    Attributes
    ----------
    step, kind : str
        The step's name and kind.
    state : str
        ``failed`` (it ran and failed) or ``not_run`` (a step it depends on failed).
    reason : str
        Why, in one line.
    study_name, study_text : str
        The study of the run (its file's text).
    time : str
        When it was recorded (ISO 8601, UTC).
    """

    step: str
    kind: str
    state: str
    reason: str
    study_name: str
    study_text: str
    time: str = ""


def marker_path(out: Path, step: str) -> Path:
    """The marker of step ``step`` in the output folder ``out``."""
    return Path(out) / f"{step}{MARKER_SUFFIX}"


def write_failure(out: Path, failure: StepFailure) -> Path:
    """Record ``failure`` atomically (temporary file, fsync, rename); returns its path."""
    if not failure.time:
        failure = StepFailure(**dict(asdict(failure), time=datetime.now(timezone.utc)
                                     .replace(microsecond=0).isoformat()))
    final = marker_path(out, failure.step)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = final.parent / f".{final.name}.{uuid.uuid4().hex[:8]}.tmp"
    try:
        with open(tmp, "w", encoding="utf-8") as fh:
            json.dump(asdict(failure), fh, indent=1)
            fh.write("\n")
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, final)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return final


def read_failures(out: Path) -> dict[str, StepFailure]:
    """The markers of the output folder ``out`` by step name (unreadable ones left out)."""
    found: dict[str, StepFailure] = {}
    for p in sorted(Path(out).glob(f"*{MARKER_SUFFIX}")):
        if p.name.startswith("."):
            continue
        try:
            f = StepFailure(**json.loads(p.read_text(encoding="utf-8")))
        except (OSError, ValueError, TypeError):
            continue
        found[f.step] = f
    return found


def clear_failures(out: Path) -> None:
    """Remove every marker of the output folder ``out`` (a run starting)."""
    for p in Path(out).glob(f"*{MARKER_SUFFIX}"):
        p.unlink(missing_ok=True)


__all__ = ["FAILED", "MARKER_SUFFIX", "NOT_RUN", "StepFailure", "clear_failures",
           "marker_path", "read_failures", "write_failure"]
