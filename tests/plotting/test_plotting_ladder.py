"""A gait that catches bars is drawn on its ladder: the bars (the one it starts from and each
one it catches) and the hook of the attached end over its bar, in the filmstrip and the
animations; a wall gait's figures have neither."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from PIL import Image

from monkeystudy.plotting import plot_filmstrip, trajectory, write_animation
from monkeystudy.plotting.drawing import Folder
from monkeystudy.plotting.gait import first_cycles, ladder_bars
from monkeystudy.plotting.kinds.stability import DRAWINGS, on_ladder

ROOT = Path(__file__).resolve().parents[2]
SPACING = 0.34          # m, studies/acromonk_gait.yaml's bars, travelling in -x
CYCLES = 2


@pytest.fixture(scope="module")
def ladder_run(tmp_path_factory) -> Path:
    """studies/acromonk_gait.yaml's gait run from its refine step for two cycles."""
    from monkeystudy.study.loader import load_study
    from monkeystudy.study.runner import run_study
    text = (ROOT / "studies" / "acromonk_gait.yaml").read_text()
    head = text[:text.index("\nsteps:") + 1].replace(
        "../data/acromonk/model/acromonk.urdf", str(ROOT / "data/acromonk/model/acromonk.urdf"))
    study = head + (
        "steps:\n"
        "  - {name: refine, kind: refine, start: [-3.5645540592, -6.4017840885], "
        "xatol: 1.0e-10, fatol: 1.0e-18, maxiter: 2000, maxfev: 4000}\n"
        f"  - {{name: cycles, kind: stability, from: refine, cycles: {CYCLES}, "
        "sample_dt: 0.01}\n")
    folder = tmp_path_factory.mktemp("ladder")
    path = folder / "ladder.yaml"
    path.write_text(study)
    run_study(load_study(path), folder / "out", workers=1)
    return folder / "out" / "cycles.nc"


@pytest.fixture(scope="module")
def ladder_ds(ladder_run):
    with xr.open_dataset(ladder_run) as ds:
        return ds.load()


def test_the_bars_are_the_start_bar_and_each_caught_bar(ladder_ds):
    """Two catches per cycle, 0.34 m apart in -x from the start's bar at the origin."""
    bars = ladder_bars(ladder_ds, trajectory(ladder_ds))
    expected = np.column_stack([-SPACING * np.arange(2 * CYCLES + 1),
                                np.zeros(2 * CYCLES + 1)])
    np.testing.assert_allclose(bars, expected, rtol=0, atol=1e-9)


def test_the_filmstrip_draws_the_bars_and_the_hook_over_the_held_bar(ladder_ds):
    fig = plot_filmstrip(ladder_ds)
    traj = trajectory(ladder_ds)
    bars = ladder_bars(ladder_ds, traj)
    drawn = [a for a in fig.findobj() if a.get_gid() == "bars"]
    poses = [a for a in fig.findobj() if a.get_gid() == "pose"]
    hooks = [a for a in fig.findobj() if a.get_gid() == "hook"]
    assert len(drawn) == len(poses) >= 8              # the ladder in every frame
    for a in drawn:
        np.testing.assert_array_equal(np.column_stack([a.get_xdata(), a.get_ydata()]), bars)
    assert len(hooks) == len(poses)                   # every frame hangs from a bar
    for h in hooks:
        at = np.array([h.get_xdata()[0], h.get_ydata()[0]])
        assert np.min(np.hypot(*(bars - at).T)) <= 1e-9
    texts = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert "hook on its bar (attached end)" in texts and "attached end (magnet on)" not in texts


def test_a_wall_gait_is_drawn_without_bars_or_hooks(datasets):
    s = datasets["stability_1"]
    assert ladder_bars(s, trajectory(s)).shape == (0, 2)
    fig = plot_filmstrip(s)
    assert not [a for a in fig.findobj() if a.get_gid() in ("bars", "hook")]
    texts = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    assert "attached end (magnet on)" in texts


def test_the_ladder_animation_is_declared_for_bar_gaits_only(ladder_run, built_study):
    def folder(path):
        return Folder(path.parent, {}, lambda p: xr.open_dataset(p))
    assert ("stability", "ladder") in DRAWINGS
    assert on_ladder(ladder_run, folder(ladder_run))
    wall = built_study / "stability_1.nc"
    assert not on_ladder(wall, folder(wall))


def test_the_ladder_animation_shows_the_first_cycles_in_real_time(ladder_ds, tmp_path):
    """One cycle at 10 frames per second: its duration's frames plus the end held 1 s."""
    traj = first_cycles(ladder_ds, trajectory(ladder_ds), 1)
    t_cross = float(ladder_ds["t_cross"][0])
    assert traj.t[-1] == pytest.approx(t_cross, abs=1e-12) and traj.t[-1] < float(
        ladder_ds["time"][-1])
    seen = []
    paths = write_animation(ladder_ds, tmp_path / "ladder", {}, fps=10.0, max_frames=300,
                            fmt="gif", cycles=1,
                            progress=lambda done, total: seen.append(total))
    assert seen[-1] == int(t_cross * 10.0) + 1 + 10
    with Image.open(paths[0]) as im:
        assert im.format == "GIF"
