"""The grid step's figures: the error surface, the error map with the refined minima, the
swap-time map (drawn in :mod:`monkeystudy.plotting.maps`)."""
from __future__ import annotations

from pathlib import Path

from ..drawing import Drawing, Folder
from ..maps import plot_error_map, plot_error_surface, plot_swap_time_map


def refine_datasets(path: Path, folder: Folder) -> list[Path]:
    """The study's refine datasets (their minima are marked on the maps)."""
    return list(folder.files.get("refine", []))


def has_swap_times(path: Path, folder: Folder) -> bool:
    """The grid names its cycles' swap times (the horizontal gait's datasets do)."""
    return "t_switch" in folder.loaded(path)


#: how the grid step's figures are drawn
DRAWINGS = {
    ("grid", "surface"): Drawing(
        title="sqrt(error) surface",
        caption="The study's figure 3: sqrt(error) over the grid; the flat floor is where no gait "
                "reaches the swap. Look for the valley along the floor's border. Gaps are jumps "
                "of the error (the swap moves to another swing), not missing data; dots are "
                "points with a gait in no cell of the surface.",
        draw=lambda d: plot_error_surface(d[0]), cost=3.0),
    ("grid", "map"): Drawing(
        title="error map with minima",
        caption="The study's figures 4, 9 and 10: the error truncated at 5, the refined minima "
                "marked. Dark is a small error: the gaits lie in the dark valley.",
        draw=lambda d: plot_error_map(d[0], d[1:]),
        extra_inputs=refine_datasets, cost=2.0),
    ("grid", "swap_time"): Drawing(
        title="swap time over the grid",
        caption="When the swap comes: a jump in colour is a start whose swap comes on a later "
                "swing. A minimum on the far side of such a jump is a gait of another kind than "
                "the study's first-swing gait.",
        draw=lambda d: plot_swap_time_map(d[0], d[1:]),
        extra_inputs=refine_datasets, applies=has_swap_times),
}
