"""How a declared figure is drawn: each figure module lists its :class:`Drawing` objects under
``(step kind, figure suffix)`` in a ``DRAWINGS`` dict; the report looks them up for the figures
each step kind declares (:class:`monkeystudy.study.steps.base.Figure`)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping, Sequence


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
    """How to draw one figure of a step's dataset.

    ``draw(datasets)`` returns a :class:`matplotlib.figure.Figure` from the datasets of its
    inputs (the step's own first, then ``extra_inputs(path, folder)``); an ``animation``
    instead writes its own files: ``draw(datasets, base, provenance) -> paths``. ``applies``
    says whether the dataset supports the figure at all. An ``across`` figure is drawn once
    per study folder from every dataset of its kind (``figures/<kind>_<suffix>``), when there
    are at least two.
    """

    draw: Callable
    extra_inputs: Callable[[Path, Folder], list[Path]] = no_extra_inputs
    applies: Callable[[Path, Folder], bool] = always
    animation: bool = False
    across: bool = False
