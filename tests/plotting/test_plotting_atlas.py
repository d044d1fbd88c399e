"""The atlas step's figure (monkeystudy.plotting.kinds.atlas): drawn for an atlas no route step
of the study plans with."""
from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import xarray as xr
from matplotlib.text import Text

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


def dense_atlas() -> xr.Dataset:
    """An atlas of 12 gaits at rises 0.05 m apart and then 0.01 m apart (the rise family of
    tools/rise_family.py and a pumping climb), MFPTs estimated and bounded."""
    rises = [-0.30, -0.25, -0.20, -0.15, -0.10, -0.05, 0.0, 0.01, 0.02, 0.03, 0.04, 0.1]
    n = len(rises)
    mfpt = np.array([200.0, 200, 1e4, 3e3, 200, 200, 200, 150, 80, 60, 20, 40])
    censored = mfpt == 200.0
    names = [f"rise_{r:.2f}" for r in rises[:-1]] + ["climb"]
    return xr.Dataset(
        {"gait_dx": ("gait", np.linspace(0.8, 1.2, n)), "gait_dy": ("gait", np.array(rises)),
         "gait_spectral_radius": ("gait", np.array([0.63, 0.47, 0.46, 0.34, 0.33, 0.41, 0.45,
                                                    0.69, 0.68, 0.70, 0.71, 0.57])),
         "gait_mfpt": ("gait", mfpt), "gait_mfpt_low": ("gait", mfpt / 2),
         "gait_mfpt_high": ("gait", np.where(censored, np.nan, mfpt * 2)),
         "gait_mfpt_censored": ("gait", censored),
         "gait_survival_runs": ("gait", np.full(n, 200, np.int32)),
         "gait_survival_failed": ("gait", np.where(censored, 0, 200).astype(np.int32))},
        coords={"gait": names}, attrs={"step_name": "atlas", "study_name": "gait_atlas"})


@pytest.mark.parametrize("gid", ["label_rho", "label_mfpt"])
def test_no_two_labels_of_a_dense_atlas_overlap(gid):
    """Gaits 0.01 m apart in rise: each label is raised above the ones it would overlap, and
    every label stays inside its axis."""
    fig = plot_gait_atlas(dense_atlas())
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    labels = [a for a in fig.findobj() if a.get_gid() == gid]
    assert len(labels) == 12
    boxes = [Text.get_window_extent(a, renderer) for a in labels]    # the leader left out
    for i, a in enumerate(boxes):
        for b in boxes[i + 1:]:
            assert not a.overlaps(b), (a, b)
    for label, box in zip(labels, boxes):
        assert box.y1 <= label.axes.get_window_extent(renderer).y1 + 0.5


def test_an_mfpt_interval_unbounded_above_sets_no_axis_limit():
    """A gait whose MFPT interval has no upper end (gait_mfpt_high inf: runs that fail early,
    none late) is drawn with the others, the axis' limits finite."""
    ds = dense_atlas()
    high = ds["gait_mfpt_high"].values.copy()
    high[8] = np.inf
    fig = plot_gait_atlas(ds.assign(gait_mfpt_high=("gait", high)))
    ax = next(a for a in fig.findobj() if a.get_gid() == "label_mfpt").axes
    lo, hi = ax.get_ylim()
    assert np.isfinite(lo) and np.isfinite(hi) and hi > float(ds["gait_mfpt"].max())


def test_a_lower_bound_with_early_failures_says_how_many_failed():
    """An MFPT that is a lower bound (no failure late in the runs) of a gait some of whose runs
    failed early names those failures, not 'none failed'."""
    ds = dense_atlas()
    failed = ds["gait_survival_failed"].values.copy()
    failed[0] = 5                                      # rise_-0.30: censored
    fig = plot_gait_atlas(ds.assign(gait_survival_failed=("gait", failed)))
    notes = {t.get_text().split("\n")[0]: t.get_text() for t in fig.findobj()
             if t.get_gid() == "label_mfpt"}
    assert notes["rise_-0.30"] == "rise_-0.30\n≥ 200, 5 of 200 runs failed early"
    assert notes["rise_-0.25"] == "rise_-0.25\n≥ 200"
