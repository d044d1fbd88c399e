"""How the figures of a study's steps are named: ``figures/<step>_<suffix>`` (one per declared
figure of the step's kind, :attr:`~monkeystudy.study.steps.base.StepKind.figures`), or
``figures/<kind>_<suffix>`` for a figure drawn across all steps of a kind. The study file's
check (:func:`figure_name_clash`) and the report name them here, so that no two steps of a
valid study make figures of the same file name.
"""
from __future__ import annotations

from .steps import REGISTRY
from .steps.base import Figure


def figure_name(figure: Figure, step: str, kind: str) -> str:
    """The file name of ``figure`` in ``figures/``, without extension: ``<step>_<suffix>`` for
    step ``step``, or ``<kind>_<suffix>`` for an ``across`` figure of kind ``kind``."""
    return f"{kind if figure.across else step}_{figure.suffix}"


def figure_name_clash(step, figures: dict[str, tuple[str, str, str]]) -> str | None:
    """Why ``step``'s figures cannot be named as they would be (:func:`figure_name`): one of
    them, or the figure across its kind's steps, is named like an earlier step's figure.
    ``figures``: the names taken so far, each with what makes it (step name, "" for a figure
    across steps; kind; suffix); ``step``'s are added. None when all is well.
    """
    kind = REGISTRY[step.kind]
    mine = {figure_name(f, step.name, kind.name):
            ("" if f.across else step.name, kind.name, f.suffix) for f in kind.figures}

    def what(owner: tuple[str, str, str]) -> str:
        name, kind_name, suffix = owner
        return (f"the {kind_name} figure {suffix} of step {name!r}" if name else
                f"the {kind_name} figure {suffix} across the {kind_name} steps")

    for name, owner in mine.items():
        taken = figures.get(name)
        if taken is not None and taken != owner:
            return (f"figure file {name} would be both {what(taken)} and {what(owner)} "
                    "(a figure is named <step>_<figure>): rename one of the two steps")
    for name, owner in mine.items():
        figures.setdefault(name, owner)
    return None


__all__ = ["figure_name", "figure_name_clash"]
