"""The refine step's figure: the best vertex's error per Nelder-Mead iteration (drawn in
:mod:`monkeystudy.plotting.maps`)."""
from __future__ import annotations

from pathlib import Path

from ..drawing import Drawing, Folder
from ..maps import plot_refine_convergence


def has_iterations(path: Path, folder: Folder) -> bool:
    """The dataset holds at least one iterate with its error."""
    ds = folder.loaded(path)
    return ds.sizes.get("iteration", 0) > 0 and "iterate_error" in ds


#: how the refine step's figure is drawn
DRAWINGS = {
    ("refine", "convergence"): Drawing(
        title="Nelder-Mead convergence",
        caption="The best vertex's error per Nelder-Mead iteration, one line per start: a line "
                "that flattens above the tolerance stalled; one that ends at the iteration limit "
                "did not converge.",
        draw=lambda d: plot_refine_convergence(d[0]),
        applies=has_iterations),
}
