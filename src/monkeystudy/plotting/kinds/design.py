"""Figures of design datasets (docs/datasets.md, "design"): where an open-loop gait is stable.

* :func:`plot_design_map` - the spectral radius per step over the two most influential free
  parameters (the least over the others), the rho = 1 contour, failures blank, the grid's and
  the refined best designs marked;
* :func:`plot_design_multipliers` - the best design's multipliers on the unit circle,
  variational equations (filled) and finite differences (open);
* :func:`plot_design_replay` - the best design's open-loop replays (exact timing and the
  controller tick): section error, kinetic energy and pivot height per cycle, and the decay of
  a perturbation against the leading multiplier;
* the filmstrip of the best design's cycle is :func:`monkeystudy.plotting.gait.plot_filmstrip`
  on the dataset's ``sample`` variables.

:data:`DRAWINGS` registers them under ``("design", suffix)``. Artists carry ``gid`` s (in each
docstring) so the tests can read back their data.
"""
from __future__ import annotations

import math
import warnings

import numpy as np
from matplotlib.colors import LogNorm
from matplotlib.lines import Line2D
from matplotlib.patches import Circle
from matplotlib.ticker import MaxNLocator

from ..labels import OUTLINE, attr_float, run_line, two_titles
from ..common import (
    BLACK, BLUE, GREEN, ORANGE, VERMILLION, count, json_attr, new_figure, style,
)
from ..drawing import Drawing
from ..gait import plot_filmstrip
from .survival import noise_values_text

#: axis labels of the design parameters (name -> label with units)
LABELS = {
    "t_switch": "swap time after the vertical  [s]",
    "motor_start": "motor start after the swap  [s]",
    "t_motor": "motor pulse duration  [s]",
    "torque": "motor torque  [N m]",
    "pulse2_start": "second pulse start after the swap  [s]",
    "pulse2_duration": "second pulse duration  [s]",
    "pulse2_torque": "second pulse torque  [N m]",
    "com": "CG of link 1 from end A  [m]",
    "inertia": "link inertia about its CG  [kg m²]",
    "mass_ratio": "mass ratio m2 / m1",
    "length_ratio": "length ratio L2 / L1",
}


#: the zorder of the replay traces (the exact-timing one above, the error bound above both)
TRACE_Z = 2.0
#: the colour of the rho = 1 contour (its legend entry draws the same)
RHO_ONE_COLOUR = VERMILLION


def axis_label(ds, name: str) -> str:
    """The axis label of design parameter ``name``: a schedule's or robot's from
    :data:`LABELS`, a segment's from its coordinate (meaning and units)."""
    if name in LABELS:
        return LABELS[name]
    v = ds[name].attrs if name in ds else {}
    return f"{v.get('long_name', name)}  [{v.get('units', '1')}]"


def influence(rho: np.ndarray, dims: list[str]) -> list[str]:
    """The free parameters ordered by influence on ``log rho``: the spread (max - min) of
    the least ``log rho`` over the others, along each parameter."""
    with np.errstate(invalid="ignore", divide="ignore"):
        logr = np.log(rho)
    spread = {}
    for k, d in enumerate(dims):
        others = tuple(j for j in range(len(dims)) if j != k)
        with warnings.catch_warnings():
            # a line of designs without a gait has no least rho: NaN, as wanted
            warnings.simplefilter("ignore", RuntimeWarning)
            profile = np.nanmin(np.where(np.isfinite(logr), logr, np.nan), axis=others) \
                if others and np.any(np.isfinite(logr)) else logr
        fin = profile[np.isfinite(profile)]
        spread[d] = float(fin.max() - fin.min()) if fin.size else -1.0
    return sorted(dims, key=lambda d: -spread[d])


def _best_text(ds) -> str:
    names = json_attr(ds, "parameters", [])
    # a schedule's pulse always, then the searched parameters
    shown = [n for n in ("torque", "motor_start", "t_motor")
             if n not in names and "best_" + n in ds.attrs] + names
    parts = [f"{n} {attr_float(ds, 'best_' + n):.4g}" for n in shown]
    bal = ds.attrs.get("balance", "none")
    if bal != "none":
        parts.append(f"{bal} {attr_float(ds, 'best_' + bal):.4g} (balance)")
    return ", ".join(parts)


def plot_design_map(ds):
    """Spectral radius per step over the two most influential parameters.

    gids: ``rho_map`` (the mesh), ``rho_one`` (the rho = 1 contour, when the map crosses 1),
    ``grid_best``, ``best`` (the markers).
    """
    rho = np.asarray(ds["spectral_radius"].transpose(*ds["status"].dims).values, float)
    dims = list(ds["status"].dims)
    order = influence(rho, dims)
    shown = order[:2]
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)     # all-NaN lines: NaN, as wanted
        others = tuple(k for k, d in enumerate(dims) if d not in shown)
        r = np.nanmin(rho, axis=others) if others and np.any(np.isfinite(rho)) else rho
    kept = [d for d in dims if d in shown]
    n_ok = int(ds.attrs.get("designs_with_gait", 0))
    more = f"; least over {', '.join(d for d in dims if d not in shown)}" \
        if len(dims) > 2 else ""
    with style():
        fig = new_figure(figsize=(8.0, 7.0))
        body = two_titles(fig, ("Spectral radius of the full return map, height included, "
                                "per design" if ds.attrs.get("height_in_map")
                                else "Spectral radius of the open-loop return map per design"),
                          f"{count(ds.attrs.get('designs', r.size), 'design')}, {n_ok} "
                          f"with a gait{more}; balance: {ds.attrs.get('balance')}. "
                          f"{ds.attrs.get('verdict', '')}. {run_line(ds, tick=False)}")
        ax = body.add_subplot()
        if len(kept) == 1:
            x = ds[kept[0]].values
            ax.plot(x, r, "o-", color=BLUE, gid="rho_map")
            ax.axhline(1.0, color=RHO_ONE_COLOUR, ls="--", lw=1.2, label="ρ = 1",
                       gid="rho_one")
            ax.set_xlabel(axis_label(ds, kept[0]))
            ax.set_ylabel("spectral radius ρ per step")
            ax.set_yscale("log")
            ax.legend(loc="best", fontsize=8.5)
        else:
            xd, yd = kept[1], kept[0]          # C order: rows are the first kept dim
            x, y = ds[xd].values, ds[yd].values
            mesh = ax.pcolormesh(x, y, r, shading="nearest", cmap="viridis_r", gid="rho_map",
                                 norm=_log_norm(r))
            cb = body.colorbar(mesh, ax=ax)
            cb.set_label("spectral radius ρ per step (blank: no gait)")
            fin = np.isfinite(r)
            if fin.sum() >= 4 and np.nanmin(r) < 1.0 < np.nanmax(r):
                cs = ax.contour(x, y, np.where(fin, r, np.nan), levels=[1.0],
                                colors=RHO_ONE_COLOUR, linewidths=2.0)
                cs.set_gid("rho_one")
                ax.plot([], [], color=RHO_ONE_COLOUR, lw=2.0, label="ρ = 1 (stable where ρ < 1)")
            ax.set_xlabel(axis_label(ds, xd))
            ax.set_ylabel(axis_label(ds, yd))
            gb = np.unravel_index(np.nanargmin(np.where(fin, r, np.inf)), r.shape) \
                if fin.any() else None
            if gb is not None:
                # wider than the star, hollow: a best design at the grid's best rings it
                ax.plot([x[gb[1]]], [y[gb[0]]], "s", ms=24, mfc="none", mec=ORANGE, mew=2.2,
                        gid="grid_best", zorder=4, label=f"best of the grid, ρ = {r[gb]:.4g}")
            bx, by = attr_float(ds, "best_" + xd), attr_float(ds, "best_" + yd)
            chosen = ("the design chosen by survival" if ds.attrs.get("chosen_by") == "survival"
                      else "best design")
            ax.plot([bx], [by], "*", ms=16, color=VERMILLION, mec=BLACK, gid="best", zorder=5,
                    label=f"{chosen}, ρ = {attr_float(ds, 'best_spectral_radius'):.4g}")
            # below the axes: a legend in them covers a row of designs; the grid's best
            # at the star's size there
            handles, labels = ax.get_legend_handles_labels()
            handles = [Line2D([], [], ls="none", marker="s", ms=11, mfc="none", mec=ORANGE,
                              mew=2.2) if h.get_gid() == "grid_best" else h for h in handles]
            body.legend(handles, labels, loc="outside lower center", fontsize=8.5,
                        ncols=min(len(handles), 3), frameon=False)
    return fig


def _log_norm(r):
    fin = r[np.isfinite(r) & (r > 0)]
    if fin.size == 0:
        return None
    lo, hi = float(fin.min()), float(fin.max())
    if hi <= lo * 1.0001:
        hi = lo * 1.01
    return LogNorm(lo, hi)


def plot_design_multipliers(ds):
    """The best design's multipliers and the unit circle.

    gids: ``multipliers`` (variational, filled), ``multipliers_fd`` (finite differences,
    open), ``unit_circle``.
    """
    lam = ds["best_multipliers_real"].values + 1j * ds["best_multipliers_imag"].values
    lam_fd = ds["best_multipliers_fd_real"].values + 1j * ds["best_multipliers_fd_imag"].values
    steps = int(ds.attrs.get("steps_per_cycle", 1))
    with style():
        fig = new_figure(figsize=(7.0, 7.2))
        body = two_titles(fig, ("Multipliers of the best open-loop design"
                                if "best_t_switch" in ds.attrs else
                                "Multipliers of the best design" + (
                                    ": the full map, the height included"
                                    if ds.attrs.get("height_in_map") else "")),
                          f"{_best_text(ds)}; ρ per step "
                          f"{attr_float(ds, 'best_spectral_radius'):.6g} (fd "
                          f"{attr_float(ds, 'best_spectral_radius_fd'):.6g})"
                          f"{'; a cycle is two steps' if steps == 2 else ''}. "
                          f"{run_line(ds, tick=False)}")
        ax = body.add_subplot()
        ax.add_patch(Circle((0, 0), 1.0, fill=False, color="0.4", lw=1.2, ls="--",
                            gid="unit_circle"))
        ax.plot(lam.real, lam.imag, "o", ms=10, color=BLUE, gid="multipliers",
                label="variational equations")
        ax.plot(lam_fd.real, lam_fd.imag, "o", ms=15, mfc="none", mec=VERMILLION, mew=1.5,
                gid="multipliers_fd", label="finite differences")
        # the moduli in one box: multipliers close together would write over each other
        ax.text(0.98, 0.98, "|λ| (variational equations):\n" + "\n".join(
                    f"{abs(v):.6g}" for v in lam), transform=ax.transAxes, ha="right",
                va="top", fontsize=9, gid="moduli",
                bbox={"boxstyle": "round", "fc": "white", "ec": "0.7"})
        m = max(1.2, 1.15 * float(np.max(np.abs(np.concatenate([lam, lam_fd])))))
        ax.set_xlim(-m, m)
        ax.set_ylim(-m, m)
        ax.set_aspect("equal")
        ax.axhline(0, color="0.8", lw=0.6)
        ax.axvline(0, color="0.8", lw=0.6)
        ax.set_xlabel("Re λ")
        ax.set_ylabel("Im λ")
        ax.legend(loc="lower left", fontsize=9)
    return fig


def plot_design_replay(ds):
    """The best design's replays per cycle and the decay of a perturbation.

    gids: ``error_<i>``, ``kinetic_energy_<i>``, ``pivot_height_<i>`` (replay ``i``),
    ``decay`` (the perturbed run's distance), ``predicted`` (``rho^steps`` per cycle).
    """
    ticks = ds["replay_tick"].values
    cycle = ds["cycle"].values
    colours = [BLUE, VERMILLION, GREEN, ORANGE]
    with style():
        fig = new_figure(figsize=(11.0, 8.6))
        body = two_titles(fig, ("Open-loop replay" if "best_t_switch" in ds.attrs else
                                "Replay (the gait's own controller)")
                          + " of the best design from its fixed point",
                          f"{_best_text(ds)}; ρ per step "
                          f"{attr_float(ds, 'best_spectral_radius'):.6g}. "
                          f"{ds.attrs.get('verdict', '')}. {run_line(ds, tick=False)}")
        axs = body.subplots(2, 2)
        done = ds["cycles_completed"].values
        walked = ds["cycles_walked"].values if "cycles_walked" in ds else done
        for i, t in enumerate(ticks):
            label = (f"{'exact timing' if t == 0 else f'{t * 1e3:g} ms tick'}: "
                     f"{count(done[i], 'cycle')} within the bound")
            if walked[i] != done[i]:
                label += f", {int(walked[i])} walked"
            c = colours[i % len(colours)]
            # exact timing on top, outlined: the tick's noisy traces would hide a steady one
            exact = dict(lw=2.0, zorder=TRACE_Z + 1, path_effects=OUTLINE) if t == 0 else \
                dict(lw=1.0, zorder=TRACE_Z, alpha=0.85)
            for ax, key in zip((axs[0, 0], axs[0, 1], axs[1, 0]),
                               ("error", "kinetic_energy", "pivot_height")):
                y = ds[f"replay_{key}"].values[i]
                ax.plot(cycle, y, "-", color=c, gid=f"{key}_{i}", label=label, **exact)
        axs[0, 0].set_yscale("log")
        bound = attr_float(ds, "error_bound")
        if math.isfinite(bound):
            axs[0, 0].axhline(bound, color=BLACK, ls="--", lw=1.6, zorder=TRACE_Z + 2,
                              path_effects=OUTLINE, gid="error_bound",
                              label=f"error bound {bound:g}")
        axs[0, 0].set_ylabel("section error vs the fixed point\n[rad² + rad² s⁻²]")
        axs[0, 1].set_ylabel("kinetic energy at the vertical  [J]")
        axs[1, 0].set_ylabel("height of the attached end  [m]")
        # cycles on a linear axis: the height drifts linearly and the energy wanders about its
        # level, which a logarithmic cycle axis would bend into a late blow-up; the error is
        # on a log scale, where growth or decay by a factor per cycle is a straight line
        for ax in (axs[0, 0], axs[0, 1], axs[1, 0]):
            ax.set_xlabel("gait cycle")
            ax.set_xlim(0.0, max(float(np.max(cycle)) if cycle.size else 1.0, 1.0) + 0.5)
            ax.xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
        # below the panels: the traces fill the panels' width
        handles, labels = axs[0, 0].get_legend_handles_labels()
        body.legend(handles, labels, loc="outside lower center", ncols=min(len(handles), 3),
                    fontsize=8.5, frameon=False)
        d = ds["perturbation_distance"].values
        k = ds["decay_cycle"].values
        ax = axs[1, 1]
        growth = attr_float(ds, "decay_growth")     # NaN: too few cycles to fit
        ax.semilogy(k, d, "o-", ms=3, color=BLUE, gid="decay",
                    label=(f"perturbed run (fitted {growth:.4g} / cycle)" if math.isfinite(growth)
                           else "perturbed run (growth not fitted: fewer than 3 cycles in its "
                                "window)"))
        lam = attr_float(ds, "multiplier_power")
        if d.size and math.isfinite(lam):
            ax.semilogy(k, d[0] * lam ** (k - 1.0), "--", color=VERMILLION, gid="predicted",
                        label=f"leading multiplier: {lam:.4g} per cycle")
        positive = d[np.isfinite(d) & (d > 0)]
        if positive.size:
            # the run's decades: the prediction beyond the run's floor leaves the panel
            ax.set_ylim(10.0 ** (math.floor(math.log10(positive.min())) - 0.5),
                        10.0 ** (math.ceil(math.log10(positive.max())) + 0.5))
        ax.set_xlabel("cycle")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True, min_n_ticks=1))
        ax.set_ylabel("distance from the fixed point  |z_k − z*|")
        ax.legend(fontsize=8.5, loc="upper right")
        ax.set_title("decay of a perturbation along the leading eigenvector", fontsize=9)
    return fig


def plot_design_screen(ds):
    """The screened candidates: the fraction of their survival runs that completed, against
    their spectral radius; the chosen one (the first) starred.

    gids: ``candidates``, ``chosen``.
    """
    rho = ds["screen_spectral_radius_fd"].values
    survived = 100.0 * ds["screen_survived"].values
    a = ds.attrs
    noise = json_attr(ds, "screen_noise", {})
    on = noise_values_text(noise if isinstance(noise, dict) else {})
    with style():
        fig = new_figure(figsize=(7.4, 5.2))
        body = two_titles(fig, "Candidates screened by survival",
                          f"{count(rho.size, 'candidate')}, each "
                          f"{count(a['screen_runs'], 'run')} of up to "
                          f"{count(a['screen_max_cycles'], 'cycle')} on the "
                          f"{float(a['screen_tick']) * 1e3:g} ms tick; {on}; "
                          f"seed {int(a['screen_seed'])}; the design checked is the one "
                          f"that lasts. {run_line(ds, tick=False)}")
        ax = body.subplots()
        ax.plot(rho, survived, "o", ms=9, color=BLUE, gid="candidates",
                label="candidate (by the objective: the least spectral radius first)")
        ax.plot(rho[:1], survived[:1], "*", ms=18, color=VERMILLION, mec=BLACK, gid="chosen",
                label=f"chosen: ρ = {rho[0]:.4g}, {survived[0]:.4g} % of its runs completed")
        ax.set_xlabel("spectral radius ρ per step (finite differences)")
        ax.set_ylabel(f"runs that completed all {count(a['screen_max_cycles'], 'cycle')}"
                      "  [%]")
        ax.set_ylim(-5, 105)
        ax.legend(loc="best", fontsize=8.5)
    return fig


def best_rates(ds) -> tuple[float, float]:
    """The best design's ``(dtheta1, dtheta2)`` [rad s-1] (the film is its cycle; the
    dataset's ``dtheta1``, ``dtheta2`` name the starting gait)."""
    return attr_float(ds, "best_dtheta1"), attr_float(ds, "best_dtheta2")


def has_screen(ds) -> bool:
    """Whether the design dataset holds a survival screen of its candidates."""
    return "screen_survived" in ds


def has_film(ds) -> bool:
    """Whether the dataset's layout holds the best design's cycle (it may be empty)."""
    return all(v in ds for v in ("A", "joint", "B"))


DRAWINGS = {
    ("design", "map"): Drawing(
        title="spectral radius over the design grid",
        caption="The spectral radius per step over the two most influential free parameters (the "
                "smallest over the others), the rho = 1 contour drawn, the grid's failures blank "
                "and the best design marked: where, if anywhere, the gait is stable (a schedule's "
                "open-loop map; a sequence gait's full map, the height included).",
        draw=lambda d: plot_design_map(d[0])),
    ("design", "multipliers"): Drawing(
        title="multipliers of the best design",
        caption="The best design's multipliers on the unit circle, by variational equations and "
                "by finite differences (they coincide): a design is stable when all lie inside.",
        draw=lambda d: plot_design_multipliers(d[0])),
    ("design", "replay"): Drawing(
        title="replay of the best design",
        caption="The best design run from its fixed point (a schedule open loop, a sequence gait "
                "by its own controller), with exact timing and on the controller tick: section "
                "error, kinetic energy and pivot height per cycle (the 2009 study's figures 5-7), "
                "and the decay of a small perturbation against the leading multiplier.",
        draw=lambda d: plot_design_replay(d[0]), cost=2.0),
    ("design", "filmstrip"): Drawing(
        title="one cycle of the best design",
        caption="The best design's gait cycle frame by frame, with its schedule below.",
        draw=lambda d: plot_filmstrip(d[0], gait=best_rates(d[0])), cost=3.0,
        applies=lambda path, folder: has_film(folder.loaded(path))),
    ("design", "screen"): Drawing(
        title="candidates screened by survival",
        caption="With a screen: each candidate's share of survival runs that completed, against "
                "its spectral radius; the design checked (starred) is the one that lasts, which "
                "need not be the most contracting.",
        draw=lambda d: plot_design_screen(d[0]),
        applies=lambda path, folder: has_screen(folder.loaded(path))),
}
