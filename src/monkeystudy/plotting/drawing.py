"""How a declared figure is drawn and what it says: each figure module lists its
:class:`Drawing` objects under ``(step kind, figure suffix)`` in a ``DRAWINGS`` dict; the report
looks them up for the figures each step kind declares
(:class:`monkeystudy.study.steps.base.Figure`). A figure's title and caption are its drawing's,
outside the code that keys the datasets: editing them recomputes nothing.

A drawing whose dataset holds nothing the figure could show (a swap-time map without a single
gait, a replay that fell before its first cycle) raises :class:`NothingToDraw` with the reason;
the report records the figure as skipped, says why in its log and on the study's page, and
does not count it as a failure.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping, Sequence


class NothingToDraw(Exception):
    """The dataset holds nothing this figure could show; ``reason`` says what is missing, as
    a sentence fragment a reader of the study page understands (``"no point of the grid has
    a gait"``)."""

    def __init__(self, reason: str):
        super().__init__(reason)
        self.reason = reason


@dataclass(frozen=True)
class Folder:
    """A study folder's datasets by step kind, and the loaded ones the planning looked into."""

    path: Path
    files: Mapping[str, Sequence[Path]]
    loaded: Callable[[Path], object]     # path -> its (cached) xarray Dataset


def no_extra_inputs(path: Path, folder: Folder) -> list[Path]:
    return []


def always(path: Path, folder: Folder) -> bool:
    return True


@dataclass(frozen=True)
class Drawing:
    """How to draw one figure of a step's dataset, and what it says.

    ``title`` says what it shows (progress lines, the file's metadata); ``caption`` what to
    look at (the study's HTML page). ``draw(datasets)`` returns a :class:`matplotlib.figure.Figure` from the datasets of its
    inputs (the step's own first, then ``extra_inputs(path, folder)``); an ``animation``
    instead writes its own files: ``draw(datasets, base, provenance) -> paths``. Either may
    raise :class:`NothingToDraw`. ``applies`` says whether the dataset's layout has the figure
    at all (a sequence gait's grid has no swap time); a dataset of the right layout whose
    numbers leave nothing to draw is a :class:`NothingToDraw`. ``cost`` orders the drawing
    (longest first). An ``across`` figure is drawn once
    per study folder from every dataset of its kind (``figures/<kind>_<suffix>``), when there
    are at least two.
    """

    title: str
    caption: str
    draw: Callable
    extra_inputs: Callable[[Path, Folder], list[Path]] = no_extra_inputs
    applies: Callable[[Path, Folder], bool] = always
    animation: bool = False
    across: bool = False
    #: how long it takes to draw, relative to a simple figure: the report starts the longest
    #: first, so that the processes finish together
    cost: float = 1.0
