"""The atlas step's figure: its gaits' spectral radius and MFPT against their rise per step
(:func:`monkeystudy.plotting.kinds.route.plot_gait_atlas`), drawn for an atlas no route step
of the study plans with (a route step that plans with it draws the same figure as its own
``atlas`` figure)."""
from __future__ import annotations

import json
from pathlib import Path

from ..drawing import Drawing, Folder
from .route import plot_gait_atlas


def no_route_plans_with(path: Path, folder: Folder) -> bool:
    """No route dataset of the study folder was planned from this atlas (its step's
    ``from``)."""
    name = folder.loaded(path).attrs.get("step_name")
    for route in folder.files.get("route", ()):
        step = json.loads(folder.loaded(route).attrs.get("step", "{}") or "{}")
        if step.get("from") == name:
            return False
    return True


#: how the atlas step's figures are drawn
DRAWINGS = {
    ("atlas", "gaits"): Drawing(
        title="the gaits of the atlas",
        caption="Each gait of the atlas against how far one step rises: its spectral radius "
                "(below 1 the gait's own map returns to its cycle) and how many steps it "
                "lasts on average under the survival noise, with the 95 % interval; an arrow "
                "is a lower bound (no run failed late). The colour is the step's length.",
        draw=lambda d: plot_gait_atlas(d[0]),
        applies=no_route_plans_with),
}
