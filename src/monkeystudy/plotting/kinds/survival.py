"""Figures of survival datasets (docs/datasets.md, "survival"): how long gaits last under
noise.

* :func:`plot_survival` - the fraction of runs that failed before each number of cycles, one
  line per noise level (log cycles; the fraction linear below one run's share, log above);
* :func:`plot_mfpt` - the mean first-passage time against the swept noise (log-log), 95 %
  intervals, lower bounds as arrows; the right axis in metres;
* :func:`plot_failure_modes` - for each level, the share of runs by how they ended;
* :func:`plot_height_drift` - each completed run's height change after its cycles;
* :func:`plot_mfpt_comparison` - every survival step of a study on one MFPT axis.

:data:`DRAWINGS` registers them under ``("survival", suffix)``. Artists carry ``gid`` s (in
each docstring) so the tests can read back their data.
"""
from __future__ import annotations

import math
import re
import textwrap
from typing import Sequence

import matplotlib
import numpy as np
from matplotlib.lines import Line2D
from matplotlib.ticker import FuncFormatter
from matplotlib.transforms import ScaledTranslation

from ...analysis.survival import SOURCES as NOISE_SOURCES
from ..labels import run_line, two_titles
from ..common import (
    BLACK, BLUE, GREEN, ORANGE, PURPLE, SKY, VERMILLION, count, finite, fmt_tick, json_attr,
    new_figure, plain_log_labels, style,
)
from ..drawing import Drawing, NothingToDraw

#: each noise source's name on a figure, in the order the figures list them: the sources of
#: :data:`~monkeystudy.analysis.survival.SOURCES`, no more and no fewer (a test holds them)
LABELS = {
    "timing": "timing jitter",
    "latency": "actuation latency (per run, uniform up to)",
    "angle": "angle-sensor noise",
    "rate": "rate-sensor noise",
    "height": "height-sensor noise",
    "energy": "energy-sensor noise",
    "torque": "torque error",
    "mass": "mass uncertainty",
    "com": "CG uncertainty",
    "inertia": "inertia uncertainty",
    "theta2": "start θ2 perturbation",
    "dtheta1": "start θ̇1 perturbation",
    "dtheta2": "start θ̇2 perturbation",
    "pivot_viscous": "pivot viscous friction uncertainty",
    "pivot_coulomb": "pivot Coulomb friction uncertainty",
    "joint_viscous": "joint viscous friction uncertainty",
    "joint_coulomb": "joint Coulomb friction uncertainty",
    "bar_spacing": "bar spacing error (per run)",
}
#: a noise source's SI units as a figure shows them: (unit text, scale from the SI value)
SHOWN_UNITS = {"s": ("ms", 1e3), "m": ("mm", 1e3), "1": ("%", 100.0), "rad": ("rad", 1.0),
               "rad s-1": ("rad/s", 1.0), "J": ("J", 1.0), "N m": ("N m", 1.0),
               "N m s": ("N m s", 1.0)}
#: each noise source: (variable, label, unit text, scale to the label's unit), in the order
#: of :data:`LABELS` (a source without a label is named as it is declared, last)
SOURCES = {s.name: (f"noise_{s.name}", LABELS.get(s.name, s.name), *SHOWN_UNITS[s.units])
           for s in sorted(NOISE_SOURCES, key=lambda s: (s.name not in LABELS,
                                                         list(LABELS).index(s.name)
                                                         if s.name in LABELS else 0))}
FAILURE_COLOURS = {"survived": GREEN, "fell": VERMILLION, "no_switch": ORANGE,
                   "energy_not_restored": PURPLE, "no_return_to_vertical": SKY,
                   "error_bound": BLUE, "stalled": "#999999", "horizon": BLACK}
#: failure modes in words where the flag's name is terse
FAILURE_WORDS = {"horizon": "horizon (a guard never fired)"}
METHOD_MEAN, METHOD_TAIL, METHOD_LOWER_BOUND = 0, 1, 2
#: joins a noise source's name, value and unit (``com 1 %``): a wrapped line never splits them
NBSP = "\u00a0"


#: a number (or a pair in brackets) and the unit after it (``428 ms``, ``(4.8, -1.6) rad/s``)
NUMBER_UNIT = re.compile(r"([\d)]) (ms|mm|%|rad/s|rad|J|s)\b")


def glue_units(text: str) -> str:
    """``text`` with each number joined to its unit by a non-breaking space."""
    return NUMBER_UNIT.sub(lambda m: m.group(1) + NBSP + m.group(2), text)


def source_value(source: str, value: float, unit: str) -> str:
    """``com 1 %``: a source's value, its name, number and unit joined by non-breaking
    spaces."""
    return f"{source}{NBSP}{value:.3g}{NBSP}{unit}"


def _swept(ds) -> list[str]:
    s = json_attr(ds, "swept", [])
    return [x for x in s if x in SOURCES] if isinstance(s, list) else []


def noise_axis(ds) -> tuple[str, np.ndarray, str]:
    """The noise the levels sweep: ``(source, values in the label's unit, axis label)``; the
    first swept source (else the first non-zero one, else timing)."""
    swept = _swept(ds)
    source = swept[0] if swept else next(
        (k for k, (v, *_rest) in SOURCES.items() if v in ds and np.any(ds[v].values > 0)),
        "timing")
    var, label, unit, scale = SOURCES[source]
    x = np.asarray(ds[var].values, float) * scale
    # sources swept together with the same values share the axis (e.g. mass, CG, inertia)
    same = [s for s in swept if s != source and SOURCES[s][2] == unit
            and np.array_equal(np.asarray(ds[SOURCES[s][0]].values, float) * scale, x)]
    if same:
        label = ", ".join([label] + [SOURCES[s][1] for s in same])
    if not levels_on_one_axis(ds, x, swept):
        return LEVEL_AXIS, np.arange(x.size, dtype=float), "noise level"
    return source, x, f"{label}  [{unit}]"


#: the axis of levels that no one noise orders (:func:`levels_on_one_axis`)
LEVEL_AXIS = "level"


def levels_on_one_axis(ds, x: np.ndarray, swept: list[str]) -> bool:
    """Whether the levels are ordered by the axis ``x``: no two levels at the same ``x``, and
    every other swept source growing (or staying) as ``x`` grows. Levels that vary several
    sources independently (jitter 1 and 2 ms, each with and without a friction error) are
    not: a line through them along one source's axis would read as that source's effect."""
    if np.unique(np.round(x, 12)).size != x.size:
        return False
    order = np.argsort(x)
    for source in swept:
        values = np.asarray(ds[SOURCES[source][0]].values, float)[order]
        if np.any(np.diff(values) < 0):
            return False
    return True


def level_ticks(ax, ds) -> None:
    """Each level named under its tick, its non-zero noise on short lines."""
    n = ds.sizes["level"]
    ax.set_xticks(np.arange(n), [level_text(ds, i, width=24) for i in range(n)], fontsize=6)
    ax.set_xlim(-0.5, n - 0.5)


#: characters per line of a noise level's label in a legend or beside a bar
LEVEL_WIDTH = 48


def level_text(ds, i: int, width: int | None = None) -> str:
    """The non-zero noise of level ``i``, short (``timing 1 ms, angle 1e-4 rad``); with
    ``width``, on lines of at most that many characters (broken between sources, so that a
    level with many sources keeps its figure's layout)."""
    parts = []
    for source, (var, label, unit, scale) in SOURCES.items():
        if var in ds and float(ds[var].values[i]) > 0:
            parts.append(source_value(source, float(ds[var].values[i]) * scale, unit))
    if not parts:
        return "no noise"
    if width is None:
        return ", ".join(parts)
    lines = [parts[0]]
    for part in parts[1:]:
        if len(lines[-1]) + 2 + len(part) <= width:
            lines[-1] += ", " + part
        else:
            lines[-1] += ","
            lines.append(part)
    return "\n".join(lines)


def gait_text(ds) -> str:
    a = ds.attrs
    replay = ("open-loop replay" if a.get("replay") == "open_loop"
              else "state-based controller")
    start = f"({float(a['dtheta1']):.4g}, {float(a['dtheta2']):.4g}) rad/s"
    times = ""
    if finite(a.get("t_switch")) and finite(a.get("t_motor")) and a.get("replay") == "open_loop":
        times = f", swap {float(a['t_switch']) * 1e3:.4g} ms, motor {float(a['t_motor']) * 1e3:.4g} ms"
    return f"{replay} from {start}{times}"


def fixed_noise(ds, leave: str | None = None) -> str:
    """The noise sources that are the same at every level (``angle 0.0001 rad``), short;
    without the source ``leave`` (a figure's noise axis, which shows it)."""
    swept = set(_swept(ds)) | {leave}
    parts = []
    for source, (var, label, unit, scale) in SOURCES.items():
        if source not in swept and var in ds and float(ds[var].values[0]) > 0:
            parts.append(source_value(source, float(ds[var].values[0]) * scale, unit))
    return ", ".join(parts)


#: what a noise value is under each distribution of :class:`~monkeystudy.analysis.survival.Noise`
DISTRIBUTION_WORDS = {"gaussian": "gaussian draws (values: standard deviations)",
                      "uniform": "uniform draws (values: half-widths)"}
#: the noise sources drawn once per run uniformly on [0, value), whatever the distribution
UNIFORM_PER_RUN = frozenset(s.name for s in NOISE_SOURCES if s.uniform_per_run)


def noise_text(ds) -> str:
    """The noise of the levels, each source under the distribution the dataset draws it
    from: ``gaussian draws (values: standard deviations): at every level timing 1 ms, mass
    1 %; latency drawn once per run uniformly on [0, 1 ms)``."""
    fixed = [p for p in fixed_noise(ds).split(", ") if p]
    return _noise_words(str(ds.attrs.get("noise_distribution", "gaussian")), fixed,
                        _swept(ds), "at every level ")


def noise_values_text(values: dict) -> str:
    """Noise given as a study file's flat ``{source: value [SI], "distribution": ...}`` (a
    design screen's ``screen_noise``) in words, each source under its distribution, values in
    the figures' units (:func:`noise_text`)."""
    parts = []
    for source, (_var, _label, unit, scale) in SOURCES.items():
        v = values.get(source)
        if isinstance(v, (int, float)) and v > 0:
            parts.append(source_value(source, float(v) * scale, unit))
    return _noise_words(str(values.get("distribution", "gaussian")), parts, [], "")


def _noise_words(dist: str, fixed: list[str], swept: list[str], every: str) -> str:
    shape = DISTRIBUTION_WORDS.get(dist, f"{dist} draws")
    drawn = [s for s in swept if s not in UNIFORM_PER_RUN]
    per_run = [p for p in fixed if p.split(NBSP)[0] in UNIFORM_PER_RUN]
    fixed = [p for p in fixed if p not in per_run]
    parts = []
    if drawn or fixed:
        parts.append(shape + ": " + ", ".join(
            ([f"{', '.join(drawn)} as swept"] if drawn else [])
            + ([f"{every}{', '.join(fixed)}"] if fixed else [])))
    for s in swept:
        if s in UNIFORM_PER_RUN:
            parts.append(f"{s} as swept, drawn once per run uniformly on [0, value)")
    for p in per_run:
        name, value = p.split(NBSP, 1)
        parts.append(f"{name} drawn once per run uniformly on [0,{NBSP}{value})")
    return "; ".join(parts) if parts else "no noise"


def _subtitle(ds) -> str:
    a = ds.attrs
    bound = float(a.get("error_bound", math.inf))
    advance = float(a.get("min_advance", -math.inf))
    fail = ", ".join(["fell", "missed an event"]
                     + ([f"error > {bound:g}"] if math.isfinite(bound) else [])
                     + ([f"advanced < {advance:g} m in a cycle"] if math.isfinite(advance)
                        else []))
    return (f"{gait_text(ds)}; {count(a['runs'], 'run')} per level, up to "
            f"{count(a['max_cycles'], 'cycle')}; failure: {fail}\n{fmt_tick(a.get('tick'))}; "
            f"{noise_text(ds)}; seed {a.get('seed')}; " + run_line(ds, tick=False))


#: legend entries of the interval markers
LOWER_BOUND_LABEL = "lower bound (no failure late in the window)"
OPEN_ABOVE_LABEL = "interval open above (no late failure in some resamples)"


def marker_handles(est_open: bool, bound: bool, colour=BLACK) -> list:
    out = []
    if est_open:
        out.append(Line2D([], [], ls="none", marker=r"$\uparrow$", ms=14, color=colour,
                          label=OPEN_ABOVE_LABEL))
    if bound:
        out.append(Line2D([], [], ls="none", marker=r"$\Uparrow$", ms=14, color=colour,
                          label=LOWER_BOUND_LABEL))
    return out


def _colours(n: int):
    cmap = matplotlib.colormaps["viridis"]
    return [cmap(0.1 + 0.8 * k / max(n - 1, 1)) for k in range(n)]


def plot_survival(ds):
    """The fraction of runs that failed before each number of cycles (one less the survival
    fraction), one step line per noise level; the fraction on a scale linear below one run
    in all and logarithmic above, so that one failure in a thousand runs stands off zero as
    far as one in a hundred stands off it.

    gids: ``survival_<level>`` (y: the failed fraction).
    """
    c = np.asarray(ds["cycle"].values, float)
    s = np.asarray(ds["survival"].values, float)
    n = ds.sizes["level"]
    runs = int(ds.attrs.get("runs", ds.sizes.get("run", 1)))
    with style():
        fig = new_figure(figsize=(7.4, 5.4))
        body = two_titles(fig, f"Survival under noise: {ds.attrs.get('step_name')}",
                          _subtitle(ds))
        ax = body.subplots()
        for i, col in enumerate(_colours(n)):
            # cycle 0 cannot sit on a log axis: the curve starts at cycle 1
            keep = c >= 1
            ax.step(c[keep], 1.0 - s[i, keep], where="post", color=col, lw=2,
                    gid=f"survival_{i}", label=level_text(ds, i, LEVEL_WIDTH))
        ax.set_xscale("log")
        plain_log_labels(ax.xaxis)
        # a survival of 0.993 sits 0.007 below 1: linear up to one run's share, then decades
        ax.set_yscale("symlog", linthresh=1.0 / max(runs, 1), linscale=0.5)
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
        ax.set_ylim(0.0, 1.0)
        ax.axhline(0.0, color="0.3", lw=0.8, zorder=1)
        ax.set_xlim(1, max(float(ds.attrs["max_cycles"]), 2))
        ax.set_xlabel("cycles completed  c")
        ax.set_ylabel("fraction of runs that failed before c cycles\n(1 − survival; "
                      f"one run in all: {1.0 / max(runs, 1):.3g})")
        if n > 4:
            body.legend(loc="outside lower center", title="noise level", fontsize=8.5,
                        ncols=min(n, 4), frameon=False)
        else:
            ax.legend(loc="best", title="noise level", fontsize=8.5)
    return fig


def has_mfpt(ds) -> bool:
    """Whether any level has an MFPT (or a lower bound) above 0 cycles: what a log axis can
    show."""
    method = np.asarray(ds["mfpt_method"].values, int)
    shown = np.where(method == METHOD_LOWER_BOUND, np.asarray(ds["mfpt_low"].values, float),
                     np.asarray(ds["mfpt"].values, float))
    return bool(np.any(np.isfinite(shown) & (shown > 0)))


#: why an MFPT figure is skipped when no level has an MFPT above 0 cycles
NO_MFPT = "every MFPT is 0 cycles (each run failed in its first cycle): nothing to show on " \
          "a log axis; the failure modes show how the runs ended"


def _mfpt_points(ax, x, ds, colour, label, gid, metres: bool = False, dodge: float = 0.0,
                 line: bool = True):
    """MFPT with its interval against ``x``; lower bounds as upward arrows; the artists
    moved ``dodge`` points sideways (to set several steps at the same noise side by
    side); ``line``: the estimates joined (not for levels no one noise orders)."""
    pre = "mfpt_distance" if metres else "mfpt"
    y, lo, hi = (np.asarray(ds[f"{pre}{s}"].values, float) for s in ("", "_low", "_high"))
    method = np.asarray(ds["mfpt_method"].values, int)
    bound = method == METHOD_LOWER_BOUND
    est = ~bound & np.isfinite(y)
    drawn = []
    if est.any():
        top = np.where(np.isfinite(hi[est]), hi[est] - y[est], 0.0)
        bars = ax.errorbar(x[est], y[est], yerr=[y[est] - lo[est], top], color=colour,
                           marker="o", capsize=3, lw=1.8, label=label, gid=gid,
                           ls="-" if line else "none")
        drawn += [a for a in bars.get_children() if a is not None]
        open_top = est & ~np.isfinite(hi)
        if open_top.any():
            drawn += ax.plot(x[open_top], y[open_top] * 3.0, ls="none", marker=r"$\uparrow$",
                             ms=14, color=colour, gid=f"{gid}_open")
    if bound.any():
        drawn += ax.plot(x[bound], lo[bound], ls="none", marker=r"$\Uparrow$", ms=16,
                         color=colour, gid=f"{gid}_bound", label=None if est.any() else label)
    if dodge:
        shift = ax.transData + ScaledTranslation(dodge / 72.0, 0.0, ax.figure.dpi_scale_trans)
        for artist in drawn:
            artist.set_transform(shift)
    return bool((est & ~np.isfinite(hi)).any()), bool(bound.any())


def plot_mfpt(ds):
    """MFPT [cycles] against the swept noise, log-log, with 95 % intervals; lower bounds
    (no failure late in the window) as double arrows at the bound. The right axis converts
    cycles to metres at the runs' mean advance per cycle.

    gids: ``mfpt`` (the error bars), ``mfpt_bound`` (lower bounds), ``mfpt_open`` (estimates
    whose interval has no upper end).
    """
    if not has_mfpt(ds):
        raise NothingToDraw(NO_MFPT)
    source, x, xlabel = noise_axis(ds)
    by_level = source == LEVEL_AXIS
    with style():
        fig = new_figure(figsize=(7.4, 5.4))
        body = two_titles(fig, f"Mean first-passage time to failure: "
                          f"{ds.attrs.get('step_name')}", _subtitle(ds))
        ax = body.subplots()
        method = np.asarray(ds["mfpt_method"].values, int)
        estimated = bool(np.any((method != METHOD_LOWER_BOUND)
                                & np.isfinite(np.asarray(ds["mfpt"].values, float))))
        # with no estimate at all, the bounds carry the lower bound's own legend entry
        est_open, bound = _mfpt_points(ax, x, ds, BLUE, "MFPT, 95 % interval" if estimated
                                       else "MFPT: " + LOWER_BOUND_LABEL, "mfpt",
                                       line=not by_level)
        bound_values = np.asarray(ds["mfpt_low"].values, float)
        for xi, lo, m in zip(x, bound_values, method):
            if m == METHOD_LOWER_BOUND and np.isfinite(lo):
                ax.annotate(f"≥ {lo:.3g} cycles", (xi, lo), xytext=(12, 0),
                            textcoords="offset points", va="center", fontsize=8.5,
                            color=BLUE, gid="mfpt_bound_value")
        bound = bound and estimated
        ax.set_xscale("log" if np.all(x > 0) else "linear")
        ax.set_yscale("log")
        plain_log_labels(ax.yaxis)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("mean cycles before failure")
        adv = np.asarray(ds["advance_per_cycle"].values, float)
        adv = adv[np.isfinite(adv)]
        if adv.size and float(np.mean(adv)) > 0:
            a = float(np.mean(adv))
            sec = ax.secondary_yaxis("right", functions=(lambda v: v * a, lambda v: v / a))
            sec.set_ylabel(f"metres before failure (at {a:.3g} m per cycle)")
            plain_log_labels(sec.yaxis)
        handles, _ = ax.get_legend_handles_labels()
        ax.legend(handles=handles + marker_handles(est_open, bound, BLUE), loc="best",
                  fontsize=8.5)
        if by_level:
            level_ticks(ax, ds)
        elif x.size > 1 and np.all(x > 0):
            ax.set_xlim(x.min() / 2, x.max() * 2)
    return fig


#: the least width of a bar segment of a failure mode some run ended by [share of runs]: one
#: run in a thousand is 0.001, a sliver no one sees (the counts beside the bar are exact)
LEAST_SHARE = 0.015


def shown_shares(counts: np.ndarray) -> np.ndarray:
    """The bar widths of each level's failure modes: their shares of the runs, a mode some
    run ended by at least :data:`LEAST_SHARE` wide (taken from the widest mode)."""
    share = counts / np.maximum(counts.sum(axis=1, keepdims=True), 1)
    shown = np.where(counts > 0, np.maximum(share, LEAST_SHARE), 0.0)
    for i in range(shown.shape[0]):
        if counts[i].any():
            widest = int(np.argmax(share[i]))
            shown[i, widest] -= shown[i].sum() - share[i].sum()
    return shown


def plot_failure_modes(ds):
    """For each noise level a horizontal bar split by how the runs ended (their share; a
    mode of a few runs at least :data:`LEAST_SHARE` wide), its counts written below it.

    gids: ``mode_<failure mode>`` (the bars), ``mode_counts_<level>`` (the counts).
    """
    counts = np.asarray(ds["failure_count"].values, float)
    modes = [str(m) for m in ds["failure_mode"].values]
    n = counts.shape[0]
    share = shown_shares(counts)
    used = [k for k in range(len(modes)) if counts[:, k].any()]
    labels = [level_text(ds, i, LEVEL_WIDTH) for i in range(n)]
    lines = sum(label.count("\n") + 1 for label in labels)
    with style():
        fig = new_figure(figsize=(7.4, 2.1 + 0.6 * n + 0.16 * (lines - n)))
        body = two_titles(fig, f"How the runs ended: {ds.attrs.get('step_name')}",
                          _subtitle(ds))
        ax = body.subplots()
        left = np.zeros(n)
        extra = [BLACK, "#999999", "#F0E442"]
        for j, k in enumerate(used):
            col = FAILURE_COLOURS.get(modes[k], extra[j % len(extra)])
            ax.barh(np.arange(n), share[:, k], left=left, color=col,
                    label=FAILURE_WORDS.get(modes[k], modes[k]), gid=f"mode_{modes[k]}",
                    height=0.5)
            left += share[:, k]
        for i in range(n):
            ax.text(1.0, i + 0.3, ", ".join(f"{int(counts[i, k])} {modes[k]}" for k in used
                                             if counts[i, k]) or "no runs",
                    ha="right", va="top", fontsize=8, gid=f"mode_counts_{i}")
        ax.set_ylim(n - 0.35, -0.45)
        ax.set_yticks(np.arange(n), labels)
        ax.set_xlim(0, 1)
        ax.set_xlabel("share of runs")
        ax.grid(False, axis="y")
        body.legend(loc="outside lower center", ncols=min(len(used), 4), frameon=False)
    return fig


#: the sideways distance between steps drawn at the same noise [pt]: a double arrow's width
DODGE = 14.0


def _share_noise(members) -> bool:
    """Whether two of the steps have a level at the same noise."""
    seen: set = set()
    for ds in members:
        xs = set(np.round(noise_axis(ds)[1], 12).tolist())
        if seen & xs:
            return True
        seen |= xs
    return False


def plot_mfpt_comparison(datasets: Sequence):
    """Every survival step's MFPT against its swept noise, log-log; one panel per swept
    source (steps sweeping the same noise share an axis).

    gids: ``mfpt_<step name>`` (and ``..._bound``, ``..._open``).
    """
    colours = [BLUE, VERMILLION, GREEN, PURPLE, ORANGE, SKY]
    empty = [str(ds.attrs.get("step_name", "?")) for ds in datasets if not has_mfpt(ds)]
    if len(empty) == len(datasets):
        raise NothingToDraw(NO_MFPT.replace("every MFPT is", "every step's MFPT is"))
    first = datasets[0]
    datasets = [ds for ds in datasets if has_mfpt(ds)]
    groups: dict[str, list] = {}
    for ds in datasets:
        source, _, xlabel = noise_axis(ds)
        # levels no one noise orders share a panel only with steps of the same levels
        key = (xlabel if source != LEVEL_AXIS else
               (xlabel,) + tuple(level_text(ds, i) for i in range(ds.sizes["level"])))
        groups.setdefault(key, []).append(ds)
    shared = any(len(members) > 1 and _share_noise(members) for members in groups.values())
    with style():
        fig = new_figure(figsize=(7.6, 2.2 + 3.6 * len(groups)))
        body = two_titles(fig, "Mean first-passage time to failure of every gait",
                          f"study {first.attrs.get('study_name')}; " +
                          run_line(first, tick=False).split(", study")[0]
                          + ("; steps at the same noise drawn side by side"
                             if shared else "")
                          + (f"; not shown (every MFPT 0 cycles): {', '.join(empty)}"
                             if empty else ""))
        axes = np.atleast_1d(body.subplots(len(groups), 1, squeeze=False)[:, 0])
        any_open = any_bound = False
        k = 0
        for ax, (key, members) in zip(axes, groups.items()):
            xlabel = key if isinstance(key, str) else key[0]
            by_level = not isinstance(key, str)
            every_x = []
            dodge = DODGE if _share_noise(members) else 0.0
            for m, ds in enumerate(members):
                source, x, _ = noise_axis(ds)
                every_x.append(x)
                name = ds.attrs.get("step_name", f"step {k}")
                fixed = fixed_noise(ds, leave=source)
                # wrapped: a label wider than the axes would run off the figure
                label = textwrap.fill(glue_units(f"{name}: {gait_text(ds)}, "
                                                 f"{fmt_tick(ds.attrs.get('tick'))}"
                                                 + (f"; also {fixed}" if fixed else "")), 60)
                est_open, bound = _mfpt_points(ax, x, ds, colours[k % len(colours)], label,
                                               f"mfpt_{name}",
                                               dodge=dodge * (m - (len(members) - 1) / 2),
                                               line=not by_level)
                any_open, any_bound = any_open or est_open, any_bound or bound
                k += 1
            # a step without noise sits at 0, which a log axis cannot show
            ax.set_xscale("log" if np.all(np.concatenate(every_x) > 0) else "linear")
            ax.set_yscale("log")
            lo, hi = ax.get_ylim()
            if 0 < lo and hi < 10 * lo:
                # values within a decade: a decade each way, or the log axis labels a sliver
                mid = math.sqrt(lo * hi)
                ax.set_ylim(mid / 10, mid * 10)
            ax.set_xlabel(xlabel)
            if by_level:
                level_ticks(ax, members[0])
            ax.set_ylabel("mean cycles before failure")
            ax.legend(handles=ax.get_legend_handles_labels()[0], loc="best", fontsize=7.5)
        handles = marker_handles(any_open, any_bound)
        if handles:
            body.legend(handles=handles, loc="outside lower center", fontsize=8,
                        frameon=False)
    return fig


def plot_height_drift(ds):
    """The attached end's height change of each run that completed ``max_cycles``
    (``height_drift``: from its start height, or with the gait's ``rise`` attribute from its
    planned height), a histogram per noise level, with the tolerance (attribute
    ``height_tolerance``) when the step set one.

    gids: ``height_drift_<level>`` (the histogram's bars), ``tolerance`` (the bounds).
    """
    if "height_drift" not in ds:
        raise NothingToDraw("the dataset has no height_drift (made before the survival step "
                            "wrote it)")
    drift = np.asarray(ds["height_drift"].values, float) * 1e3
    done = np.asarray(ds["failure"].values) == 0
    n = ds.sizes["level"]
    if not done.any():
        raise NothingToDraw("no run completed max_cycles: no height after them to show")
    tol = float(ds.attrs["height_tolerance"]) * 1e3 if "height_tolerance" in ds.attrs \
        else math.nan
    finite_done = drift[done]
    lo, hi = float(finite_done.min()), float(finite_done.max())
    if math.isfinite(tol):
        lo, hi = min(lo, -tol), max(hi, tol)
    pad = 0.05 * max(hi - lo, 1e-3)
    edges = np.linspace(lo - pad, hi + pad, 61)
    with style():
        fig = new_figure(figsize=(7.4, 5.0))
        body = two_titles(fig, f"Height change of each run: {ds.attrs.get('step_name')}",
                          _subtitle(ds))
        ax = body.subplots()
        for i, col in enumerate(_colours(n)):
            d = drift[i][done[i]]
            if not d.size:
                continue
            label = (f"{level_text(ds, i, LEVEL_WIDTH)}:\n{d.size} of "
                     f"{count(drift.shape[1], 'run')} completed, median {np.median(d):+.3g} mm")
            if "height_within_tolerance" in ds:
                label += (f", {100 * float(ds['height_within_tolerance'].values[i]):.4g} % "
                          f"within ±{tol:g} mm")
            ax.hist(d, bins=edges, histtype="stepfilled" if n == 1 else "step",
                    color=col, alpha=0.75 if n == 1 else 1.0, lw=1.8, label=label,
                    gid=f"height_drift_{i}")
        if math.isfinite(tol):
            for k, v in enumerate((-tol, tol)):
                ax.axvline(v, color=VERMILLION, ls="--", lw=1.4,
                           label=f"tolerance ±{tol:g} mm" if k == 0 else None,
                           gid="tolerance")
        # a gait with a rise: the drift is from the route's staircase, not the start
        rise = float(ds.attrs.get("rise", 0.0))
        reference = (f"planned height (start {rise:+g} m per cycle)" if rise
                     else "start height")
        ax.axvline(0.0, color="0.4", lw=0.8, ls=":", label=reference)
        ax.set_xlabel(f"attached end's height after {count(ds.attrs['max_cycles'], 'cycle')} "
                      f"less its {reference}  [mm]")
        ax.set_ylabel("runs")
        # below the axes: the histogram's peak may be anywhere
        handles, labels = ax.get_legend_handles_labels()
        body.legend(handles, labels, loc="outside lower center", fontsize=8,
                    ncols=min(len(handles), 2), frameon=False)
    return fig


#: how the survival step's figures are drawn
DRAWINGS = {
    ("survival", "survival"): Drawing(
        title="survival per cycle",
        caption="The fraction of runs that failed before each number of cycles (one less the "
                "survival), one line per noise level, on decades above one run's share: a curve "
                "that jumps at a fixed cycle count is an unstable gait drifting off; one that "
                "climbs steadily over decades is metastable.",
        draw=lambda d: plot_survival(d[0])),
    ("survival", "mfpt"): Drawing(
        title="mean first-passage time against noise",
        caption="Mean cycles (and metres) before failure against the noise level, with 95 % "
                "intervals; arrows are lower bounds (no failure to fit the tail on). The "
                "Byl-Tedrake plot: a stable gait's MFPT grows steeply as the noise shrinks.",
        draw=lambda d: plot_mfpt(d[0])),
    ("survival", "failure_modes"): Drawing(
        title="how the runs ended",
        caption="For each noise level, the share of runs by the way they stopped: fell, no swap, "
                "missed return, error bound, or survived all cycles.",
        draw=lambda d: plot_failure_modes(d[0])),
    ("survival", "height_drift"): Drawing(
        title="height change of each run",
        caption="How far each run that completed all its cycles ended above or below its start "
                "height (a gait with a rise: its planned height on the route's staircase), a "
                "histogram per noise level, with the tolerance when the step sets one: a gait "
                "whose height is neutral wanders off, one that senses its height stays within "
                "millimetres.",
        draw=lambda d: plot_height_drift(d[0])),
    ("survival", "mfpt_comparison"): Drawing(
        title="MFPT of every gait against noise",
        caption="Every survival step of the study on one axis: which gait lasts longest at each "
                "noise level.",
        draw=lambda groups: plot_mfpt_comparison([g[0] for g in groups]), across=True),
}
