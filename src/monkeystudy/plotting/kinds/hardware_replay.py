"""Figures of the ``hardware_replay`` dataset (docs/datasets.md, ``hardware_replay``).

* ``swings_train``, ``swings_held_out``: per swing of the training or the held-out logs, the
  measured angles and rates against the identified model's replay from the swing's first
  sample (:func:`plot_swings`);
* ``residuals``: the replay's angle error over time - of the whole-swing replays and of the
  replays from starts through each swing at each horizon (:func:`plot_residuals`);
* ``parameters``: the identified values with both 95 % intervals and the published values
  (:func:`plot_parameters`);
* ``held_out``: the held-out logs' RMS errors of the three models per joint and horizon, with
  the sensor floor (:func:`plot_held_out`).

Artists carry ``gid`` s (listed in each docstring) so the tests can read back their data.
"""
from __future__ import annotations

import math

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from ..common import BLACK, BLUE, GREEN, ORANGE, PURPLE, SKY, VERMILLION, YELLOW, count, \
    json_attr, new_figure, robot_name, style
from ..drawing import Drawing, NothingToDraw
from ..labels import OUTLINE, RATE, SUB, two_titles, values_of

#: colour of each model
MODEL_COLOUR = {"identified": BLUE, "published_damping": GREEN, "frictionless": VERMILLION}
#: colours of the held-out logs in the residuals figure (none of the models')
LOG_COLOURS = (ORANGE, PURPLE, SKY, BLACK, "#8c564b", YELLOW, "#7f7f7f", "#17becf")
#: colour and marker of each horizon (shortest first)
HORIZON_STYLE = ((BLUE, "o"), (ORANGE, "s"), (VERMILLION, "^"), (PURPLE, "D"), (BLACK, "v"))
MODEL_TITLE = {"identified": "identified", "published_damping": "published damping",
               "frictionless": "frictionless"}
JOINT_SYMBOL = {"shoulder": "θ1 (shoulder)", "elbow": "θ2 (elbow)"}
#: swings per row of a swings figure
SWINGS_PER_ROW = 2


def _labels(ds, name: str) -> list[str]:
    return [str(x) for x in np.atleast_1d(ds[name].values)]


def run_text(ds) -> str:
    """What was replayed, in one line: robot, the torque, the replay's integrator, study /
    step."""
    return (f"robot {robot_name(ds)}, the measured elbow torque as input (centred hold), "
            f"{ds.attrs.get('replay_integrator', '?')}; study {ds.attrs.get('study_name', '?')}"
            f" / {ds.attrs.get('step_name', '?')}")


def identified_text(ds) -> str:
    """The identified values, in one line."""
    names = _labels(ds, "parameter")
    units = _labels(ds, "parameter_units")
    v = values_of(ds, "identified_value")
    return "identified: " + ", ".join(f"{n} {x:.3g} {u}" for n, x, u in zip(names, v, units))


def _held_out_logs(ds) -> set[str]:
    return {n for n, h in zip(_labels(ds, "log"), values_of(ds, "held_out")) if h}


def plot_swings(ds, held_out: bool):
    """Measured against simulated angles (left of each pair) and rates (right) of every swing
    of the training (``held_out`` False) or the held-out logs: measured black, the
    identified model's replay from the swing's first sample blue (shoulder solid, elbow
    dashed), two swings per row.

    gids: ``measured_angle_<swing>_<joint>``, ``simulated_angle_<swing>_<joint>``,
    ``measured_rate_<swing>_<joint>``, ``simulated_rate_<swing>_<joint>`` (x time [s]).
    """
    logs = _held_out_logs(ds)
    swings = _labels(ds, "swing")
    swing_log = _labels(ds, "swing_log")
    hooks = _labels(ds, "swing_hook")
    chosen = [i for i, lg in enumerate(swing_log) if (lg in logs) == held_out]
    if not chosen:
        raise NothingToDraw("no " + ("held-out" if held_out else "training") + " swing")
    t = values_of(ds, "time")
    rms = values_of(ds, "swing_rms")[0]
    joints = _labels(ds, "joint")
    rows = math.ceil(len(chosen) / SWINGS_PER_ROW)
    with style():
        fig = new_figure(figsize=(13.0, 1.2 + 2.05 * rows), layout="constrained")
        which = "held-out" if held_out else "training"
        body = two_titles(
            fig, f"AcroMonk's {which} swings: measured against the identified model's replay "
                 "from each swing's first sample",
            f"black: measured (the IMU's estimate and gyro, the elbow encoder and the servo's "
            f"velocity); blue: replay with the measured torque; shoulder solid, elbow dashed. "
            f"{identified_text(ds)}.\n{run_text(ds)}")
        axes = body.subplots(rows, 2 * SWINGS_PER_ROW, squeeze=False)
        for k, i in enumerate(chosen):
            r, c = divmod(k, SWINGS_PER_ROW)
            ax_a, ax_r = axes[r, 2 * c], axes[r, 2 * c + 1]
            n = int(values_of(ds, "swing_samples")[i])
            ti = t[i, :n]
            for j, joint in enumerate(joints):
                ls = "-" if j == 0 else "--"
                for ax, what in ((ax_a, "angle"), (ax_r, "rate")):
                    ax.plot(ti, values_of(ds, f"measured_{what}")[i, :n, j], color=BLACK,
                            lw=1.1, ls=ls, gid=f"measured_{what}_{swings[i]}_{joint}")
                    ax.plot(ti, values_of(ds, f"simulated_{what}")[i, :n, j], color=BLUE,
                            lw=1.1, ls=ls, gid=f"simulated_{what}_{swings[i]}_{joint}")
            hook = "motor arm" if hooks[i] == "motor_arm" else "IMU arm"
            ax_a.set_title(f"{swings[i]}, from the {hook}: angles", loc="left", **SUB)
            ax_a.text(0.02, 0.97, f"RMS error θ1 {rms[i, 0]:.2g}, θ2 {rms[i, 1]:.2g} rad",
                      transform=ax_a.transAxes, va="top", fontsize=7.5, path_effects=OUTLINE)
            ax_r.set_title("rates", loc="left", **SUB)
            ax_a.set_ylabel("[rad]")
            ax_r.set_ylabel(RATE)
            if r == rows - 1 or k + SWINGS_PER_ROW >= len(chosen):
                ax_a.set_xlabel("time from the swing's start [s]")
                ax_r.set_xlabel("time from the swing's start [s]")
        for k in range(len(chosen), rows * SWINGS_PER_ROW):
            r, c = divmod(k, SWINGS_PER_ROW)
            axes[r, 2 * c].set_visible(False)
            axes[r, 2 * c + 1].set_visible(False)
        handles = [Line2D([], [], color=BLACK, label="measured"),
                   Line2D([], [], color=BLUE, label="identified model's replay"),
                   Line2D([], [], color="0.4", ls="-", label="shoulder θ1"),
                   Line2D([], [], color="0.4", ls="--", label="elbow θ2")]
        body.legend(handles=handles, loc="outside lower center", ncols=4, frameon=False)
    return fig


def plot_residuals(ds):
    """The replay's angle error (simulated less measured) over time, per joint (rows). Left:
    the identified model's whole-swing replays against time from each swing's start, one
    line per swing (training grey, held out coloured by log). Right: its error at each
    horizon after each start of the held-out swings, against the start's time in its
    swing. Symmetric-log scale, linear within 0.1 rad.

    gids: ``whole_<swing>_<joint>`` (x time [s], y error [rad]),
    ``starts_<model>_<joint>_<horizon index>`` (x start time, y error).
    """
    joints = _labels(ds, "joint")
    swings = _labels(ds, "swing")
    swing_log = _labels(ds, "swing_log")
    held = _held_out_logs(ds)
    models = _labels(ds, "model")
    hs = values_of(ds, "horizon")
    t = values_of(ds, "time")
    sim, meas = values_of(ds, "simulated_angle"), values_of(ds, "measured_angle")
    n = values_of(ds, "swing_samples").astype(int)
    start_swing = _labels(ds, "start_swing")
    start_time = values_of(ds, "start_time")
    err = values_of(ds, "start_error")
    on_held = np.array([swing_log[swings.index(s)] in held for s in start_swing], bool)
    held_logs = [lg for lg in _labels(ds, "log") if lg in held]
    log_colour = {lg: LOG_COLOURS[k % len(LOG_COLOURS)] for k, lg in enumerate(held_logs)}
    with style():
        fig = new_figure(figsize=(13.0, 8.4), layout="constrained")
        body = two_titles(
            fig, "AcroMonk: the replay's angle error over time",
            "simulated less measured, identified model. Left: its replay from each swing's "
            "first sample; right: its replays from measured starts every "
            f"{float(ds.attrs.get('start_every', math.nan)):g} s through each held-out swing, "
            "the error at each horizon after the start (symmetric log scale, linear within "
            "±0.1 rad). "
            f"{identified_text(ds)}.\n{run_text(ds)}")
        axes = body.subplots(len(joints), 2, squeeze=False)
        for j, joint in enumerate(joints):
            ax = axes[j, 0]
            for i, s in enumerate(swings):
                lg = swing_log[i]
                colour = log_colour.get(lg, "0.65")
                ax.plot(t[i, :n[i]], sim[i, :n[i], j] - meas[i, :n[i], j], color=colour,
                        lw=0.9 if lg in held else 0.7, gid=f"whole_{s}_{joint}")
            ax.axhline(0.0, color=BLACK, lw=0.6)
            ax.set_ylabel(f"{JOINT_SYMBOL[joint]} error [rad]")
            ax.set_xlabel("time from the swing's start [s]")
            ax.set_title(f"{JOINT_SYMBOL[joint]}: whole-swing replays, identified model",
                         loc="left", **SUB)
            ax.set_yscale("symlog", linthresh=0.1)
            ax = axes[j, 1]
            for k, h in enumerate(hs):
                colour, marker = HORIZON_STYLE[k % len(HORIZON_STYLE)]
                ax.scatter(start_time[on_held], err[0, on_held, j, k], s=11, marker=marker,
                           color=colour, alpha=0.75, linewidths=0,
                           gid=f"starts_{models[0]}_{joint}_{k}")
            ax.axhline(0.0, color=BLACK, lw=0.6)
            ax.set_yscale("symlog", linthresh=0.1)
            ax.set_xlabel("time of the start from the swing's start [s]")
            ax.set_title(f"{JOINT_SYMBOL[joint]}: error after each start, held-out swings",
                         loc="left", **SUB)
        handles = ([Line2D([], [], color="0.65", label="training swing")]
                   + [Line2D([], [], color=c, label=lg) for lg, c in log_colour.items()]
                   + [Line2D([], [], ls="none", marker=HORIZON_STYLE[k % len(HORIZON_STYLE)][1],
                             color=HORIZON_STYLE[k % len(HORIZON_STYLE)][0],
                             label=f"{h:g} s after the start") for k, h in enumerate(hs)])
        body.legend(handles=handles, loc="outside lower center", ncols=6, frameon=False)
    return fig


def plot_parameters(ds):
    """One panel per identified parameter: its value (dot), the swing-clustered 95 %
    interval (thick bar) and the windows-independent one (thin bar, offset), the published
    model's value (green diamond) and the frictionless model's (red cross).

    gids: ``value_<parameter>`` (y value), ``clustered_<parameter>``,
    ``independent_<parameter>`` (y the interval), ``published_<parameter>``,
    ``frictionless_<parameter>``.
    """
    names = _labels(ds, "parameter")
    units = _labels(ds, "parameter_units")
    v = values_of(ds, "identified_value")
    cl, ind = values_of(ds, "ci95_clustered"), values_of(ds, "ci95_independent")
    mv = values_of(ds, "model_value")
    models = _labels(ds, "model")
    with style():
        fig = new_figure(figsize=(3.0 + 2.3 * len(names), 5.6), layout="constrained")
        train = ", ".join(json_attr(ds, "train", []))
        body = two_titles(
            fig, "AcroMonk: the identified parameters with their 95 % intervals",
            f"fitted on {train}: {count(ds.attrs.get('fit_swings', 0), 'swing')}, "
            f"{count(ds.attrs.get('fit_windows', 0), 'window')} of "
            f"{float(ds.attrs.get('identify_window', math.nan)):g} s every "
            f"{float(ds.attrs.get('identify_every', math.nan)):g} s, RMS residual "
            f"{float(ds.attrs.get('fit_rms', math.nan)):.3f} rad. Thick: swing-clustered "
            "(the windows of a swing share its errors); thin: as if every residual were "
            f"independent (too narrow).\n{run_text(ds)}")
        axes = body.subplots(1, len(names), squeeze=False)[0]
        for k, (name, u) in enumerate(zip(names, units)):
            ax = axes[k]
            ax.plot([0, 0], cl[k], color=BLUE, lw=7, alpha=0.45, solid_capstyle="butt",
                    gid=f"clustered_{name}")
            ax.plot([0.25, 0.25], ind[k], color=BLUE, lw=1.6, gid=f"independent_{name}")
            ax.plot([0], [v[k]], "o", color=BLUE, ms=7, gid=f"value_{name}")
            for m, model, mk, c in ((1, "published_damping", "D", GREEN),
                                    (2, "frictionless", "x", VERMILLION)):
                if model in models:
                    i = models.index(model)
                    ax.plot([-0.25], [mv[i, k]], mk, color=c, ms=7, mew=1.6,
                            gid=f"{'published' if m == 1 else 'frictionless'}_{name}")
            ax.text(0.4, v[k], f"{v[k]:.3g}\nclustered [{cl[k, 0]:.3g}, {cl[k, 1]:.3g}]\n"
                    f"independent [{ind[k, 0]:.3g}, {ind[k, 1]:.3g}]", fontsize=7.5,
                    va="center")
            ax.set_xlim(-0.5, 2.4)
            ax.set_xticks([])
            ax.set_title(name, loc="left", **SUB)
            ax.set_ylabel(f"[{u}]")
        handles = [Line2D([], [], ls="none", marker="o", color=BLUE, label="identified"),
                   Line2D([], [], color=BLUE, lw=7, alpha=0.45, label="95 %, swing-clustered"),
                   Line2D([], [], color=BLUE, lw=1.6, label="95 %, windows independent"),
                   Line2D([], [], ls="none", marker="D", color=GREEN, label="published"),
                   Line2D([], [], ls="none", marker="x", color=VERMILLION, mew=1.6,
                          label="frictionless")]
        body.legend(handles=handles, loc="outside lower center", ncols=5, frameon=False)
    return fig


def plot_held_out(ds):
    """The held-out logs' RMS angle error per joint (rows) and horizon (columns; the last
    column the whole-swing replays) for the three models as bars per log (log scale), the
    sensor floor dashed.

    gids: ``rms_<model>_<joint>_<horizon index>`` (bar heights per held-out log),
    ``whole_<model>_<joint>``, ``floor_<joint>_<horizon index>``.
    """
    held = _held_out_logs(ds)
    logs = _labels(ds, "log")
    idx = [i for i, lg in enumerate(logs) if lg in held]
    if not idx:
        raise NothingToDraw("no held-out log")
    models = _labels(ds, "model")
    joints = _labels(ds, "joint")
    hs = values_of(ds, "horizon")
    rms = values_of(ds, "rms_error")
    whole = values_of(ds, "whole_swing_rms")
    floor = values_of(ds, "sensor_floor")
    below = int(np.sum(rms[0][idx] < rms[1][idx]))
    total = rms[0][idx].size
    x = np.arange(len(idx))
    width = 0.8 / len(models)
    with style():
        fig = new_figure(figsize=(3.2 + 3.0 * (hs.size + 1), 7.6), layout="constrained")
        body = two_titles(
            fig, f"AcroMonk's held-out logs: the replay's RMS angle error, identified model "
                 f"below the published damping in {below} of {total} (log, joint, horizon)",
            f"RMS over starts every {float(ds.attrs.get('start_every', math.nan)):g} s "
            "through each swing of the error at each horizon after the start, and over "
            "whole-swing replays. Dashed: the sensor floor, the largest std over the last "
            f"0.05 s of the catches of {', '.join(json_attr(ds, 'floor_logs', []))} (both hooks "
            "on their "
            f"bars), for the shoulder plus the IMU's drift times the horizon. "
            f"{identified_text(ds)}.\n{run_text(ds)}")
        axes = body.subplots(len(joints), hs.size + 1, squeeze=False, sharey="row")
        for j, joint in enumerate(joints):
            for k in range(hs.size + 1):
                ax = axes[j, k]
                for m, model in enumerate(models):
                    y = rms[m, idx, j, k] if k < hs.size else whole[m, idx, j]
                    ax.bar(x + (m - (len(models) - 1) / 2) * width, y, width,
                           color=MODEL_COLOUR.get(model, BLACK),
                           gid=(f"rms_{model}_{joint}_{k}" if k < hs.size
                                else f"whole_{model}_{joint}"))
                if k < hs.size:
                    ax.axhline(floor[j, k], color=BLACK, ls="--", lw=1.0,
                               gid=f"floor_{joint}_{k}")
                    ax.set_title(f"{JOINT_SYMBOL[joint]}, {hs[k]:g} s after the start",
                                 loc="left", **SUB)
                else:
                    ax.set_title(f"{JOINT_SYMBOL[joint]}, whole swing", loc="left", **SUB)
                ax.set_yscale("log")
                ax.set_xticks(x, [logs[i] for i in idx], rotation=45, ha="right",
                              fontsize=7.5)
            axes[j, 0].set_ylabel("RMS error [rad]")
        handles = [Patch(color=MODEL_COLOUR.get(m, BLACK), label=MODEL_TITLE.get(m, m))
                   for m in models] + [Line2D([], [], color=BLACK, ls="--",
                                              label="sensor floor")]
        body.legend(handles=handles, loc="outside lower center", ncols=4, frameon=False)
    return fig


#: how the hardware_replay step's figures are drawn
DRAWINGS = {
    ("hardware_replay", "swings_train"): Drawing(
        title="training swings: measured against the identified model's replay",
        caption="Each training swing replayed from its first sample with the measured elbow "
                "torque: where blue leaves black, the model and the robot part.",
        draw=lambda d: plot_swings(d[0], held_out=False)),
    ("hardware_replay", "swings_held_out"): Drawing(
        title="held-out swings: measured against the identified model's replay",
        caption="The held-out swings, replayed as the training ones: the identified model on "
                "logs it was not fitted to.",
        draw=lambda d: plot_swings(d[0], held_out=True)),
    ("hardware_replay", "residuals"): Drawing(
        title="the replay's angle error over time",
        caption="Left: how the identified model's whole-swing replay drifts from the measured "
                "swing; right: its error at each horizon after starts through the held-out "
                "swings.",
        draw=lambda d: plot_residuals(d[0])),
    ("hardware_replay", "parameters"): Drawing(
        title="identified parameters with their 95 % intervals",
        caption="Each identified value with its swing-clustered and windows-independent 95 % "
                "intervals, beside the published MuJoCo damping.",
        draw=lambda d: plot_parameters(d[0])),
    ("hardware_replay", "held_out"): Drawing(
        title="held-out errors of the three models",
        caption="Per held-out log, joint and horizon the RMS replay error of the identified "
                "model, the published damping and no friction, against the sensor floor.",
        draw=lambda d: plot_held_out(d[0])),
}
