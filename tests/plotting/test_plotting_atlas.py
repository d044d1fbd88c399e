"""The atlas step's figure (monkeystudy.plotting.kinds.atlas): drawn for an atlas no route step
of the study plans with."""
from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

from monkeystudy.plotting.drawing import Folder
from monkeystudy.plotting.kinds.atlas import DRAWINGS, no_route_plans_with
from monkeystudy.plotting.kinds.route import plot_gait_atlas
from monkeystudy.study.steps import REGISTRY


def folder(routes: dict[str, str]) -> tuple[Path, Folder]:
    """A study folder with an atlas step named ``atlas`` and a route step per entry of
    ``routes`` (its name -> the step it plans from)."""
    data = {Path("atlas.nc"): SimpleNamespace(attrs={"step_name": "atlas"})}
    for name, source in routes.items():
        data[Path(f"{name}.nc")] = SimpleNamespace(attrs={
            "step_name": name, "step": json.dumps({"kind": "route", "from": source})})
    files = {"atlas": [Path("atlas.nc")], "route": [Path(f"{n}.nc") for n in routes]}
    return Path("atlas.nc"), Folder(Path("."), files, data.__getitem__)


def test_the_atlas_kind_declares_its_gaits_figure():
    assert [f.suffix for f in REGISTRY["atlas"].figures] == ["gaits"]
    assert set(DRAWINGS) == {("atlas", "gaits")}
    assert DRAWINGS[("atlas", "gaits")].draw.__code__.co_names == ("plot_gait_atlas",)
    assert plot_gait_atlas


def test_the_atlas_draws_its_gaits_unless_a_route_planned_with_it_draws_them():
    path, alone = folder({})
    assert no_route_plans_with(path, alone)
    path, other = folder({"route": "another_atlas"})
    assert no_route_plans_with(path, other)
    path, planned = folder({"route": "atlas"})
    assert not no_route_plans_with(path, planned)
    assert DRAWINGS[("atlas", "gaits")].applies is no_route_plans_with
