"""Per-cycle figures of an open-loop repetition (``stability`` dataset; study figs. 5-8); a
sequence gait's runs (its own controller or open loop) are measured at its section.

* :func:`plot_error_per_cycle` - error at each vertical crossing, log scale (figs. 5 and 8);
  :func:`plot_error_comparison` overlays several runs;
* :func:`plot_kinetic_energy` - kinetic energy at each vertical crossing (fig. 6);
* :func:`plot_pivot_height` - height of the attached end after each swap, with the link
  length for scale, and the horizontal advance per cycle (fig. 7).
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.ticker import MaxNLocator

from .common import (
    BLUE, ERROR_UNITS, GREEN, VERMILLION, count, finite, link_lengths, new_figure,
    readable_log_axis, robot_object, run_label, status_name, style,
)
from ..analysis.gait_kind import gait_kind_text
from ..simulation import Status, kinetic_energy
from .drawing import Folder, NothingToDraw

#: Statuses that mean "the run went as long as asked" (not worth a warning on the plot).
NORMAL_END = (Status.OK, Status.END_TIME)


def gait_point(stab, refines: Sequence = ()) -> tuple[float, float] | None:
    """The initial rates ``(dtheta1, dtheta2)`` [rad s-1] a stability run repeats.

    Looked for in the dataset (scalar variables or attributes ``dtheta1``/``dtheta2``, or a
    JSON ``start``/``gait_start`` attribute), else in the ``refine`` dataset whose recorded
    times equal the run's ``t_switch``/``t_motor``.
    """
    for src in (stab.variables, stab.attrs):
        if "dtheta1" in src and "dtheta2" in src:
            try:
                v1 = src["dtheta1"]
                v2 = src["dtheta2"]
                v1 = float(getattr(v1, "values", v1))
                v2 = float(getattr(v2, "values", v2))
                return v1, v2
            except (TypeError, ValueError):
                pass
    for key in ("gait_start", "start"):
        raw = stab.attrs.get(key)
        try:
            v = json.loads(raw) if isinstance(raw, str) else raw
            if isinstance(v, dict):
                v = (v["dtheta1"], v["dtheta2"])
            if v is not None and len(v) == 2:
                return float(v[0]), float(v[1])
        except (TypeError, ValueError, KeyError):
            pass
    match = matching_refine(stab, refines)
    if match is not None:
        return float(match["dtheta1"]), float(match["dtheta2"])
    return None


def matching_refine(stab, refines: Sequence):
    """The refine dataset (one start of it) whose ``t_switch``/``t_motor`` the stability run
    replays, or None."""
    try:
        ts, tm = float(stab.attrs["t_switch"]), float(stab.attrs["t_motor"])
    except (KeyError, TypeError, ValueError):
        return None
    for r in refines:
        starts = ([r.isel(start=i) for i in range(r.sizes["start"])] if "start" in r.dims
                  else [r])
        for s in starts:
            try:
                if (math.isclose(float(s["t_switch"]), ts, rel_tol=0, abs_tol=1e-9)
                        and math.isclose(float(s["t_motor"]), tm, rel_tol=0, abs_tol=1e-9)):
                    return s
            except (KeyError, TypeError, ValueError):
                continue
    return None


def gait_text(stab, gait) -> str:
    if gait is None:
        gait = gait_point(stab)          # the run's own dtheta1/dtheta2, when it has them
    times = ""
    if finite(stab.attrs.get("t_switch")) and finite(stab.attrs.get("t_motor")):
        times = (f"swap at {float(stab.attrs['t_switch']):.3f} s, "
                 f"motor {float(stab.attrs['t_motor']):.3f} s")
    passes = int(stab.attrs.get("vertical_passes_before_swap", -1))
    if passes > 0:      # say so when the gait is not the study's first-swing kind
        times += f" ({gait_kind_text(passes)})"
    if gait is not None:
        g = f"gait ({gait[0]:.3f}, {gait[1]:.3f})"
        return f"{g}: {times}" if times else g
    return times or "open-loop gait"


def stop_note(stab, who: str = "run") -> str | None:
    """Why the run stopped early, or None when it ran all its cycles."""
    if "status" not in stab:
        return None
    code = int(stab["status"])
    if code in NORMAL_END:
        return None
    done = stab.attrs.get("cycles_completed")
    if done is None:
        done = int(np.sum(np.isfinite(np.asarray(stab["error"].values, float))))
    why = status_name(code).replace("_", " ")
    if code == Status.FELL and "max_drop" in stab.attrs:
        why += f" (attached end over {float(stab.attrs['max_drop']):g} m below the start)"
    return f"{who} stopped after cycle {int(done)}: {why}"


def nothing_per_cycle(stab, values, what: str) -> None:
    """Raise :class:`NothingToDraw` when ``values`` (one per cycle) has no finite value,
    saying why the run has none."""
    if np.isfinite(np.asarray(values, float)).any():
        return
    if "t_switch" in stab.attrs and not finite(stab.attrs.get("t_switch")):
        why = "the gait it replays has no swap time (its refine step found no gait)"
    elif "status" in stab and int(stab["status"]) not in NORMAL_END:
        why = ("the run completed no cycle: it stopped with status "
               + status_name(int(stab["status"])).replace("_", " "))
    else:
        why = "the run recorded no cycle"
    raise NothingToDraw(f"no {what} to show: {why}")


def cycle_axis(ax) -> None:
    """Whole cycles on the x axis, a tick at every cycle of a short run."""
    ax.xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))


def _finish(fig, ax, stab, title, subtitle="", step=True):
    fig.suptitle(title, x=0.02, ha="left", fontweight="bold")
    run = run_label(stab, step=step)
    sub = f"{subtitle}\n{run}" if subtitle else run
    ax.set_title(sub, fontsize=8.5, fontweight="normal", loc="left")
    cycle_axis(ax)
    ax.set_xlabel("gait cycle")


def _annotate_stop(ax, stab, x, y, slot: int = 0, colour: str = VERMILLION,
                   who: str = "run", at_swap: bool = False):
    """Mark the last cycle of a run that stopped early (cycles after it are NaN) with a cross
    whose legend entry says why. ``at_swap``: ``y`` is measured at each cycle's swap, so the
    last point can belong to a cycle that began (its swap) but never ended; the note says
    so."""
    note = stop_note(stab, who)
    ok = np.flatnonzero(np.isfinite(y) & (y > 0 if ax.get_yscale() == "log" else True))
    if note and ok.size:
        i = ok[-1]
        done = stab.attrs.get("cycles_completed")
        if at_swap and done is not None and x[i] > int(done):
            why = status_name(int(stab["status"])).replace("_", " ")
            note = (f"{who} {why}: cycle {int(x[i])}'s swap attached {abs(y[i]):.2f} m below "
                    f"the start\n({count(done, 'cycle')} completed)")
        ax.plot([x[i]], [y[i]], marker="X", ms=11, mfc=colour, mec="black", mew=0.8,
                ls="none", zorder=5, gid="stop_note" if slot == 0 else f"stop_note_{slot}",
                label=note)


def _cycle_limits(ax, stabs):
    """Show every requested cycle (a run that stopped early leaves the rest empty)."""
    n = max(int(s.sizes.get("cycle", 0)) for s in stabs)
    if n:
        ax.set_xlim(0.5, n + 0.5)


def _cycle(stab) -> np.ndarray:
    return np.asarray(stab["cycle"].values if "cycle" in stab.coords
                      else np.arange(1, stab.sizes["cycle"] + 1), float)


def _crossing(stab) -> str:
    """Where the run is measured: a sequence gait's section, else the vertical."""
    return "section crossing" if "section_theta1" in stab.attrs else "vertical crossing"


def own_controller(stab) -> bool:
    """A sequence gait run by its own controller (not replayed open loop)."""
    return stab.attrs.get("replay") == "gait"


# ----------------------------------------------------------------------------------------------
def plot_error_per_cycle(stab, *, gait=None, label: str | None = None):
    """Error against the initial state at each vertical crossing, per cycle, log scale.

    The line has ``gid`` ``error``; its ydata are the dataset's ``error`` (non-positive values
    cannot be drawn on a log axis and are masked).
    """
    return plot_error_comparison([stab], gaits=[gait], labels=[label], _single=True)


def plot_error_comparison(stabs: Sequence, *, gaits: Sequence = (), labels: Sequence = (),
                          _single: bool = False):
    """Errors per cycle of several open-loop runs on one log axis (figs. 5 and 8 together).

    Lines have ``gid`` ``error`` (one run) or ``error_<step name>``.
    """
    gaits = list(gaits) + [None] * (len(stabs) - len(gaits))
    labels = list(labels) + [None] * (len(stabs) - len(labels))
    with_data = [k for k, s in enumerate(stabs)
                 if np.any(np.asarray(s["error"].values, float) > 0)]
    if _single:
        nothing_per_cycle(stabs[0], np.where(np.asarray(stabs[0]["error"].values, float) > 0,
                                             stabs[0]["error"].values, np.nan), "error")
    elif not with_data:
        raise NothingToDraw("no run completed a cycle with an error to show")
    else:           # a run without a single cycle has no line: left out, the others shown
        stabs, gaits, labels = ([x[k] for k in with_data] for x in (stabs, gaits, labels))
    colours = [BLUE, VERMILLION, GREEN, "#CC79A7", "#E69F00", "#56B4E9"]
    with style():
        fig = new_figure(figsize=(7.0, 4.6))
        ax = fig.add_subplot()
        for k, (s, gait, lab) in enumerate(zip(stabs, gaits, labels)):
            x = _cycle(s)
            y = np.asarray(s["error"].values, float)
            yplot = np.ma.masked_less_equal(y, 0.0)
            step = s.attrs.get("step_name", f"run {k + 1}")
            ax.plot(x, yplot, marker="o", color=colours[k % len(colours)],
                    gid="error" if _single else f"error_{step}",
                    label=lab or (f"error at the {_crossing(s)}" if _single
                                  else f"{step}{' (own controller)' if own_controller(s) else ''}: "
                                       f"{gait_text(s, gait)}"))
        ax.set_yscale("log")
        for k, s in enumerate(stabs):
            _annotate_stop(ax, s, _cycle(s), np.asarray(s["error"].values, float), slot=k,
                           colour=VERMILLION if _single else colours[k % len(colours)],
                           who="run" if _single else s.attrs.get("step_name", "run"))
        _cycle_limits(ax, stabs)
        readable_log_axis(ax)
        ax.set_ylabel(f"error e at the {_crossing(stabs[0])}  {ERROR_UNITS}")
        if _single:
            title = ("Error per cycle of the gait under its own controller" if own_controller(stabs[0])
                     else "Error per cycle of the open-loop repetition")
            sub = f"Repeating {gait_text(stabs[0], gaits[0])}"
        else:
            title = ("Error per cycle of the multi-cycle runs" if any(own_controller(s) for s in stabs)
                     else "Error per cycle of the open-loop runs")
            sub = ""
        if len(stabs) > 1 or any(stop_note(s) for s in stabs):
            ax.legend(loc="best")
        _finish(fig, ax, stabs[0], title, sub, step=_single)
    return fig


def plot_kinetic_energy(stab, *, gait=None):
    """Kinetic energy [J] at each vertical crossing, per cycle (study fig. 6).

    With the gait's start point known, a dashed line marks the kinetic energy of the start
    state (what every crossing would have for a perfectly repeated gait). The data line has
    ``gid`` ``kinetic_energy``; the reference ``ke_start``.
    """
    x = _cycle(stab)
    y = np.asarray(stab["kinetic_energy"].values, float)
    nothing_per_cycle(stab, y, "kinetic energy")
    with style():
        fig = new_figure(figsize=(7.0, 4.6))
        ax = fig.add_subplot()
        ax.plot(x, y, marker="o", color=BLUE, gid="kinetic_energy",
                label=f"kinetic energy at the {_crossing(stab)}")
        k0 = _start_kinetic_energy(stab, gait)
        if k0 is not None:
            ax.axhline(k0, ls="--", color="0.35", lw=1.0, gid="ke_start",
                       label=f"at the gait start: {k0:.4g} J")
        _annotate_stop(ax, stab, x, y)
        _cycle_limits(ax, [stab])
        ax.set_ylabel("kinetic energy  [J]")
        # under the axes: inside, it would cover the last cycles, where a run falls
        fig.legend(*ax.get_legend_handles_labels(), loc="outside lower center", ncols=1,
                   frameon=False)
        _finish(fig, ax, stab, f"Kinetic energy at the {_crossing(stab)}, per cycle",
                f"Repeating {gait_text(stab, gait)}")
    return fig


def _start_kinetic_energy(stab, gait) -> float | None:
    if gait is None:
        return None
    robot = robot_object(stab)
    if robot is None:
        return None
    th1 = float(stab.attrs.get("section_theta1", 0.0))   # a sequence gait's section state
    th2 = float(stab.attrs.get("start_theta2", 0.0))
    return kinetic_energy(robot, [0.0, 0.0, th1, th2, 0.0, 0.0, float(gait[0]), float(gait[1])])


def plot_pivot_height(stab, *, gait=None):
    """Height [m] of the attached end after each swap, per cycle (study fig. 7).

    Reference lines: the start height (0) and one link length below it, so the drop reads
    against the robot's size; a second panel shows the horizontal advance per cycle
    (``x_advance``) when the dataset has it; a height held within 5 % of a link length gets
    an inset in millimetres. Lines: ``gid`` ``pivot_height``, ``x_advance``,
    ``start_height``, ``link_length``, ``pivot_height_mm`` (the inset).
    """
    x = _cycle(stab)
    y = np.asarray(stab["pivot_height"].values, float)
    nothing_per_cycle(stab, y, "height")
    has_adv = "x_advance" in stab
    lengths = link_lengths(stab)
    with style():
        fig = new_figure(figsize=(7.0, 6.2 if has_adv else 4.6))
        if has_adv:
            ax, ax2 = fig.subplots(2, 1, sharex=True, height_ratios=[2.2, 1])
        else:
            ax, ax2 = fig.add_subplot(), None
        ax.plot(x, y, marker="o", color=BLUE, gid="pivot_height",
                label="attached end at the section crossing" if "section_theta1" in stab.attrs
                else "attached end after the swap")
        ax.axhline(0.0, ls="--", color="0.35", lw=1.0, gid="start_height",
                   label="start height (attached end at the gait start)")
        if lengths is not None:
            L1 = lengths[0]
            ax.axhline(-L1, ls=":", color=VERMILLION, lw=1.2, gid="link_length",
                       label=f"one link length ({L1:g} m) below the start")
        _annotate_stop(ax, stab, x, y, at_swap="section_theta1" not in stab.attrs)
        _cycle_limits(ax, [stab])
        spread = float(np.nanmax(np.abs(y)))
        if lengths is not None and spread < 0.05 * lengths[0]:
            # a height held within millimetres is a flat line at the link's scale: zoom in
            inset = ax.inset_axes([0.3, 0.3, 0.66, 0.4])
            inset.plot(x, y * 1e3, marker=".", ms=3, lw=0.8, color=BLUE,
                       gid="pivot_height_mm")
            inset.axhline(0.0, ls="--", color="0.35", lw=1.0)
            inset.set_xlim(ax.get_xlim())
            inset.set_ylabel("[mm]", fontsize=8)
            inset.set_title("the same height in millimetres", fontsize=8, loc="left")
            inset.tick_params(labelsize=7)
        # two short lines each: one line is taller than its panel, and the labels met
        ax.set_ylabel("height of the\nattached end  [m]" if has_adv
                      else "height of the attached end  [m]")
        if ax2 is not None:
            adv = np.asarray(stab["x_advance"].values, float)
            ax2.plot(x, adv, marker="o", color=GREEN, gid="x_advance",
                     label="horizontal advance of the attached end")
            if lengths is not None:
                ax2.axhline(0.0, color="0.6", lw=0.8)
            ax2.set_ylabel("advance per\ncycle  [m]")
            ax.tick_params(labelbottom=False)
            _finish(fig, ax, stab, "Height of the attached end per cycle",
                    f"Repeating {gait_text(stab, gait)}")
            ax.set_xlabel("")
            ax2.set_xlabel("gait cycle")
            cycle_axis(ax2)
            # the two y labels in one column: their lengths differ, so aligned by hand
            fig.align_ylabels([ax, ax2])
        else:
            _finish(fig, ax, stab, "Height of the attached end per cycle",
                    f"Repeating {gait_text(stab, gait)}")
        # one legend under the panels: inside, it would cover the data or the reference lines
        handles, labels = [], []
        for a in (ax, ax2):
            if a is not None:
                h, lab = a.get_legend_handles_labels()
                handles += h
                labels += lab
        fig.legend(handles, labels, loc="outside lower center", ncols=1, frameon=False)
    return fig


# ----------------------------------------------------------------------------------------------
def stability_inputs(path: Path, folder: Folder) -> list[Path]:
    """The refine dataset a stability run needs for its gait's rates: none when the run names
    them itself, else the refine step it names, else one whose times it replays."""
    sds = folder.loaded(path)
    if "dtheta1" in sds and "dtheta2" in sds:
        return []
    refines = list(folder.files.get("refine", []))
    named = folder.path / f"{sds.attrs.get('refine_step', '')}.nc"
    if named in refines:
        return [named]
    return [p for p in refines if matching_refine(sds, [folder.loaded(p)]) is not None][:1]
