"""The stability step's figures: error, kinetic energy and the attached end's height per
cycle, all runs' errors side by side (drawn in :mod:`monkeystudy.plotting.cycles`), and the
filmstrip and animation of the replay, and on a ladder its first cycles from bar to bar
(:mod:`monkeystudy.plotting.gait`)."""
from __future__ import annotations

from pathlib import Path

from ..cycles import (
    gait_point, plot_error_comparison, plot_error_per_cycle, plot_kinetic_energy,
    plot_pivot_height, stability_inputs,
)
from ..drawing import Drawing, Folder
from ..gait import bar_offsets, has_trajectory, plot_filmstrip, write_animation

#: the cycles the ladder's animation shows, in real time
LADDER_CYCLES = 3


def run_gait(d) -> tuple[float, float] | None:
    """The gait's rates of a stability dataset and its inputs ``d``."""
    return gait_point(d[0], d[1:])


def comparison(groups):
    """All stability runs of a study side by side."""
    return plot_error_comparison([g[0] for g in groups],
                                 gaits=[gait_point(g[0], g[1:]) for g in groups])


def replay_recorded(path: Path, folder: Folder) -> bool:
    """The run recorded its trajectory (a filmstrip and an animation need it)."""
    return has_trajectory(folder.loaded(path))


def on_ladder(path: Path, folder: Folder) -> bool:
    """The run recorded its trajectory and its gait catches bars."""
    ds = folder.loaded(path)
    return has_trajectory(ds) and bool(bar_offsets(ds))


def ladder(d, base: Path, prov: dict, *, fps: float, max_frames: int,
           progress=None) -> list[Path]:
    """The first :data:`LADDER_CYCLES` cycles' animation along the ladder."""
    return write_animation(d[0], base, prov, gait=gait_point(d[0], d[1:]), fps=fps,
                           max_frames=max_frames, progress=progress, cycles=LADDER_CYCLES)


def animation(d, base: Path, prov: dict, *, fps: float, max_frames: int,
              progress=None) -> list[Path]:
    """The replay's animation, written beside the figures."""
    return write_animation(d[0], base, prov, gait=gait_point(d[0], d[1:]), fps=fps,
                           max_frames=max_frames, progress=progress)


#: how the stability step's figures are drawn
DRAWINGS = {
    ("stability", "error"): Drawing(
        title="error per cycle",
        caption="The study's figures 5 and 8: the error against the start at each cycle's end, on "
                "a log scale. A straight rise is exponential growth: the gait is unstable.",
        draw=lambda d: plot_error_per_cycle(d[0], gait=run_gait(d)),
        extra_inputs=stability_inputs),
    ("stability", "kinetic_energy"): Drawing(
        title="kinetic energy per cycle",
        caption="The study's figure 6: the kinetic energy where each cycle ends; it drifts once "
                "the gait degrades.",
        draw=lambda d: plot_kinetic_energy(d[0], gait=run_gait(d)),
        extra_inputs=stability_inputs),
    ("stability", "height"): Drawing(
        title="attached-end height per cycle",
        caption="The study's figure 7: the height of the attached end per cycle; a falling line "
                "is the robot sinking down the wall.",
        draw=lambda d: plot_pivot_height(d[0], gait=run_gait(d)),
        extra_inputs=stability_inputs),
    ("stability", "error_comparison"): Drawing(
        title="error per cycle of all multi-cycle runs",
        caption="Every multi-cycle run's error per cycle on one axis: which gait lasts longest, "
                "and whether they grow at the same rate.",
        draw=comparison, extra_inputs=stability_inputs, across=True),
    ("stability", "filmstrip"): Drawing(
        title="one gait cycle",
        caption="The study's figure 2, from data: one cycle frame by frame.",
        draw=lambda d: plot_filmstrip(d[0], gait=gait_point(d[0], d[1:])),
        extra_inputs=stability_inputs, applies=replay_recorded, cost=3.0),
    ("stability", "animation"): Drawing(
        title="animation",
        caption="The whole run as a video, the view moving with the robot: the links coloured by "
                "what the controller does, the ends that held (a magnet on a wall, a hook on its "
                "bar), and why the run stopped if it stopped early.",
        draw=animation, extra_inputs=stability_inputs, applies=replay_recorded,
        animation=True, cost=8.0),
    ("stability", "ladder"): Drawing(
        title="along the ladder",
        caption=f"The first {LADDER_CYCLES} cycles in real time on the ladder: the bars (grey) "
                "the robot starts from and catches, and the hook (gold arc) over the bar it "
                "holds; each catch snaps the hook onto its bar.",
        draw=ladder, extra_inputs=stability_inputs, applies=on_ladder,
        animation=True, cost=3.0),
}
