"""The floquet step's figure: the multipliers in the complex plane with the unit circle,
variational equations (filled) against finite differences (open), one panel per return map.

Artists carry ``gid`` s (listed in the docstring) so the tests can read back their data.
"""
from __future__ import annotations

import json
import math
import textwrap

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Circle

from ..drawing import Drawing, NothingToDraw
from ..common import (
    BLACK, BLUE, VERMILLION, new_figure, style,
)
from ..labels import (
    D1, D2, OUTLINE, attr_float, complex_of, gait_of, run_line, sci, times_of, two_titles,
    values_of,
)


#: multipliers this close to 1 are neutral (the datasets' ``neutral_tol`` when present)
NEUTRAL_TOL = 1e-6


CONTROLLERS = {
    "open_loop": "open-loop replay of the recorded times",
    "search": "state-based search controller",
}


def _classify(lam: np.ndarray, neutral_tol: float) -> list[str]:
    out = []
    for v in lam:
        if abs(v - 1.0) < neutral_tol:
            out.append("neutral")
        elif abs(v) > 1.0:
            out.append("unstable")
        else:
            out.append("stable")
    return out


CLASS_COLOUR = {"unstable": VERMILLION, "stable": BLUE, "neutral": "0.45"}


def _section_of(ds) -> float:
    """The return map's section theta1 [rad]: the gait's section, the vertical by default."""
    try:
        g = json.loads(ds.attrs.get("gait", "{}"))
    except (TypeError, ValueError):
        return 0.0
    return float(g.get("section", {}).get("theta1", 0.0))


def _cycle_of(ds) -> str:
    """What one cycle of a sequence gait's fixed point does (advance, climb, duration)."""
    if "x_advance" not in ds:
        return ""
    parts = [f"cycle: x advance {float(ds['x_advance'].values[0]):.4g} m",
             f"climb {float(ds['y_advance'].values[0]):.3g} m"]
    if "t_segment" in ds:
        parts.append(f"period {float(np.asarray(ds['t_segment'].values)[0, -1]):.4g} s")
    return ", ".join(parts) + "\n"


def _label_offsets(lam: np.ndarray, R: float) -> list[int]:
    """Vertical offsets [points] of the ``|lambda|`` labels: above a multiplier (below one in
    the lower half plane), moved to the other side or one more row out wherever a label already
    sits within 0.3 R horizontally on that row (a near-real complex pair beside a real
    multiplier would otherwise print three labels on top of each other)."""
    taken: list[tuple[float, int]] = []
    out = []
    for v in lam:
        prefer = -1 if v.imag < -1e-12 else 1
        for row in (prefer, -prefer, 2 * prefer, -2 * prefer, 3 * prefer, -3 * prefer):
            if not any(r == row and abs(v.real - x) < 0.3 * R for x, r in taken):
                break
        taken.append((v.real, row))
        out.append(11 + 12 * (row - 1) if row > 0 else -16 - 12 * (-row - 1))
    return out


def _multiplier_panel(ax, lam, fd, ntol: float, R: float, tag: str, neutral_what: str):
    """One set of multipliers ``lam`` (filled, coloured by class) and ``fd`` (open circles,
    or None) in the complex plane with the unit circle, each labelled with its modulus; gids
    ``<tag>`` ... as :func:`plot_floquet_multipliers` names them (``tag`` = ``multipliers_<c>``
    or ``full_multipliers_<c>``). Returns the multipliers' classes."""
    c = tag.split("multipliers_", 1)[1]
    prefix = tag.split("multipliers_", 1)[0]
    cls = _classify(lam, ntol)
    ax.add_patch(Circle((0, 0), 1.0, fill=False, color="0.3", lw=1.2, ls="-",
                        gid=f"{prefix}unit_circle_{c}"))
    ax.axhline(0, color="0.7", lw=0.7, zorder=0)
    ax.axvline(0, color="0.7", lw=0.7, zorder=0)
    if fd is not None:
        ax.scatter(fd.real, fd.imag, s=150, facecolors="none", edgecolors="black",
                   linewidths=1.2, zorder=4, gid=f"{prefix}multipliers_fd_{c}")
    ax.scatter(lam.real, lam.imag, s=45, c=[CLASS_COLOUR[k] for k in cls],
               edgecolors="black", linewidths=0.6, zorder=5, gid=tag)
    for k, (v, kind, dy) in enumerate(zip(lam, cls, _label_offsets(lam, R))):
        txt = f"|λ| = {abs(v):.4g}" + (f" ({neutral_what})" if kind == "neutral" else "")
        ax.annotate(txt, (v.real, v.imag), xytext=(0, dy), textcoords="offset points",
                    ha="center", fontsize=8,
                    color=CLASS_COLOUR[kind] if kind != "neutral" else "0.3",
                    path_effects=OUTLINE, zorder=6, gid=f"{prefix}modulus_{c}_{k}")
    ax.set_xlim(-R, R)                  # a square box with equal ranges: equal scales
    ax.set_ylim(-R, R)
    ax.set_box_aspect(1.0)
    ax.set_xlabel("Re λ  [1]")
    ax.set_ylabel("Im λ  [1]")
    return cls


def plot_floquet_multipliers(ds):
    """Floquet multipliers in the complex plane, one panel per controller.

    The unit circle is the stability boundary. Filled dots: multipliers by variational
    equations; open circles: by finite differences (they coincide when both are right).
    Colours: outside the circle (unstable), inside (stable), neutral (within ``neutral_tol``
    of 1: the energy level of the state-based controller, excluded from stability). Each
    multiplier is labelled with ``|lambda|``; each panel says stable / unstable. A dataset
    that analysed the full map (attribute ``height_in_map``) has a second row: the full
    map's multipliers, the attached end's height included (a neutral height is not stable).

    gids per controller ``c``: ``multipliers_<c>`` (PathCollection, offsets (Re, Im)),
    ``multipliers_fd_<c>``, ``unit_circle_<c>``, ``modulus_<c>_<k>`` (the labels); the full
    map's the same with the prefix ``full_``.
    """
    ctrls = [str(c) for c in np.atleast_1d(ds["controller"].values)]
    failures = ([str(f) for f in np.atleast_1d(ds["failure"].values)] if "failure" in ds
                else [""] * len(ctrls))
    if all(failures):
        raise NothingToDraw("no return map was analysed: " + "; ".join(
            f"{c}: {f}" for c, f in zip(ctrls, failures)))
    full = bool(int(ds.attrs.get("height_in_map", 0))) and "full_multipliers_real" in ds
    lam_all = complex_of(ds, "multipliers")
    fd_all = complex_of(ds, "multipliers_fd") if "multipliers_fd_real" in ds else None
    full_all = complex_of(ds, "full_multipliers") if full else None
    full_fd_all = complex_of(ds, "full_multipliers_fd") if full else None
    ntol = attr_float(ds, "neutral_tol", NEUTRAL_TOL)
    n = len(ctrls)
    rows = 2 if full else 1
    with style():
        fig = new_figure(figsize=(max(7.0, 4.4 * n + 0.6), 6.8 + 5.2 * (rows - 1)))
        gait = gait_of(ds)
        times = times_of(ds)
        section = _section_of(ds)
        if "sequence" in ctrls:
            what = (f"sequence gait, refined start {gait}\n" if gait else "") + \
                _cycle_of(ds)
        else:
            what = (f"open loop: {gait}" + (f", {times}" if times else "") + "\n"
                    if gait else "")
        state = (r"($\theta_2$, " + D1 + ", " + D2 + ")" + (
            r"; below, the full map: the state with y, the attached end's height relative to "
            "the start" if full else ""))
        sub = (rf"Return map P on the section $\theta_1$ = {section:.4g} rad, state "
               + state + "; a multiplier outside the unit circle makes the gait unstable\n"
               + what + run_line(ds, tick=False))
        body = two_titles(fig, "Floquet multipliers of the gait's return map", sub)
        grid = body.subplots(rows, n, squeeze=False)
        axes = np.atleast_1d(grid[0])
        finite = np.abs(np.concatenate([lam_all[np.isfinite(lam_all)]] + (
            [full_all[np.isfinite(full_all)]] if full else [])))
        R = max(1.2, 1.18 * float(finite.max()) if finite.size else 1.2)   # one scale
        for j, (ax, c) in enumerate(zip(axes, ctrls)):
            if failures[j]:
                for axj in grid[:, j]:
                    axj.set_axis_off()
                ax.set_title(f"{CONTROLLERS.get(c, c)}: NOT ANALYSED", loc="left",
                             fontsize=8.5, fontweight="normal", color=VERMILLION)
                z = values_of(ds, "fixed_point")[j]
                tried = (rf"at $\theta_2$ = {z[0]:.4g} rad, {D1} = {z[1]:.4g}, {D2} = "
                         f"{z[2]:.4g} rad s⁻¹:\n")
                ax.text(0.0, 0.9, tried + textwrap.fill(failures[j], 48),
                        transform=ax.transAxes, va="top", fontsize=8.5, gid=f"failure_{c}")
                continue
            lam = lam_all[j]
            cls = _multiplier_panel(ax, lam, None if fd_all is None else fd_all[j], ntol, R,
                                    f"multipliers_{c}", "neutral")
            stable = bool(int(ds["stable"].values[j])) if "stable" in ds else \
                all(k != "unstable" for k in cls)
            others = [abs(v) for v, k in zip(lam, cls) if k != "neutral"]
            lead = max(others) if others else math.nan
            verdict = "STABLE" if stable else "UNSTABLE"
            lines = [f"{CONTROLLERS.get(c, c)}: {verdict}",
                     f"largest |λ| = {lead:.4g}" + (" (neutral λ = 1 excluded)"
                                                    if "neutral" in cls else "")]
            if "agreement" in ds:
                lines.append(f"var. eq. vs finite diff.: max|ΔJ| / max|J| = "
                             f"{sci(float(ds['agreement'].values[j]))}")
            if "fixed_point" in ds:
                z = values_of(ds, "fixed_point")[j]
                lines.append(rf"fixed point $\theta_2$ = {z[0]:.4g} rad, {D1} = {z[1]:.4g}, "
                             f"{D2} = {z[2]:.4g} rad s⁻¹")
            ax.set_title("\n".join(lines), loc="left", fontsize=8.5,
                         fontweight="normal", color=VERMILLION if not stable else BLACK)
            if full:
                axf = grid[1, j]
                _multiplier_panel(axf, full_all[j], full_fd_all[j], ntol, R,
                                  f"full_multipliers_{c}", "neutral: the height")
                ok = bool(int(ds["full_stable"].values[j]))
                rho = float(ds["full_spectral_radius"].values[j])
                rho_fd = float(ds["full_spectral_radius_fd"].values[j])
                height = float(values_of(ds, "full_jacobian")[j][0, 0])
                axf.set_title("\n".join([
                    f"full map (y, θ2, {D1}, {D2}): {'STABLE' if ok else 'NOT STABLE'}"
                    + ("" if ok else " (height included)"),
                    f"spectral radius {rho:.10g} (finite differences {rho_fd:.10g})",
                    f"var. eq. vs finite diff.: max|ΔJ| / max|J| = "
                    f"{sci(float(ds['full_agreement'].values[j]))}",
                    f"height: dy'/dy = {height:.3g}"]), loc="left", fontsize=8.5,
                    fontweight="normal", color=BLACK if ok else VERMILLION)
        handles = [
            Line2D([], [], marker="o", ls="none", mfc="0.6", mec="black", ms=7,
                   label="variational equations (saltation matrices at the events)"),
            Line2D([], [], marker="o", ls="none", mfc="none", mec="black", ms=12, mew=1.2,
                   label="finite differences of the return map"),
            Line2D([], [], marker="o", ls="none", mfc=VERMILLION, mec="black", ms=7,
                   label="|λ| > 1: unstable"),
            Line2D([], [], marker="o", ls="none", mfc=BLUE, mec="black", ms=7,
                   label="|λ| < 1: stable"),
            Line2D([], [], marker="o", ls="none", mfc="0.45", mec="black", ms=7,
                   label=f"neutral, |λ − 1| < {sci(ntol, 1)} (the energy level"
                         + ("; the height" if full else "") + ")"),
            Line2D([], [], color="0.3", label="unit circle |λ| = 1"),
        ]
        body.legend(handles=handles, loc="outside lower center", ncols=2 if n > 1 else 1,
                    frameon=False)
    return fig


#: how the floquet step's figure is drawn
DRAWINGS = {
    ("floquet", "multipliers"): Drawing(
        title="multipliers and the unit circle",
        caption="The return map's Floquet multipliers in the complex plane: any outside the unit "
                "circle makes the gait unstable; variational equations (filled) and finite "
                "differences (open) must coincide. With height_in_map, a second row: the full "
                "map's multipliers, the attached end's height included (a multiplier 1 there is "
                "the neutral height; a catch at a sensed height makes it 0).",
        draw=lambda d: plot_floquet_multipliers(d[0])),
}
