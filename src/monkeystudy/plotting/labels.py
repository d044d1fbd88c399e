"""Text and layout the figures of every step kind share: attribute readers, the run line
under a title, two-level titles, numbers in words (:func:`sci`), axis symbols.
"""
from __future__ import annotations

import math
import re

import numpy as np
from matplotlib.patheffects import withStroke

from .common import (
    fmt_tick,
    gait_settings, json_attr, robot_name,
)

D1 = r"$\dot\theta_1$"


D2 = r"$\dot\theta_2$"


RATE = r"[rad s$^{-1}$]"


SUB = dict(fontsize=8.5, fontweight="normal")


OUTLINE = [withStroke(linewidth=2.5, foreground="white")]


def attr_float(ds, name: str, default=math.nan) -> float:
    try:
        return float(ds.attrs[name])
    except (KeyError, TypeError, ValueError):
        return default


def values_of(ds, name: str) -> np.ndarray:
    return np.asarray(ds[name].values, dtype=float)


def complex_of(ds, name: str) -> np.ndarray:
    return values_of(ds, f"{name}_real") + 1j * values_of(ds, f"{name}_imag")


def run_line(ds, *, tick: bool = True, torque: float | None = None,
             integrator: bool = True) -> str:
    """What was run, in one line: robot, motor torque (``torque`` overrides the study's, e.g.
    0 for a motorless replay), controller tick (``tick=False``: the figure sweeps or fixes it
    itself), integrator, study / step."""
    g = gait_settings(ds)
    parts = [f"robot {robot_name(ds)}"]
    if torque is not None:
        parts.append(f"τ = {torque:g} N m" if torque else "no motor torque")
    elif "motor_torque" in g:
        parts.append(f"τ = {float(g['motor_torque']):g} N m")
    if tick and "tick" in g:
        parts.append(fmt_tick(g["tick"]))
    integ = json_attr(ds, "integrator", {})
    if integrator and isinstance(integ, dict) and "method" in integ:
        s = str(integ["method"]).upper()
        if "rtol" in integ:
            s += f" rtol {float(integ['rtol']):.0e}"
        parts.append(s)
    study, step = ds.attrs.get("study_name"), ds.attrs.get("step_name")
    if study or step:
        parts.append(f"study {study or '?'}" + (f" / {step}" if step else ""))
    return ", ".join(parts)


def gait_of(ds) -> str | None:
    """``gait (dtheta1, dtheta2) rad s-1`` from a dataset's gait attributes, or None."""
    d1, d2 = attr_float(ds, "dtheta1"), attr_float(ds, "dtheta2")
    if not (math.isfinite(d1) and math.isfinite(d2)):
        return None
    th2 = attr_float(ds, "start_theta2")
    if math.isfinite(th2):                       # a sequence gait: its section state
        s = f"gait (θ2 {th2:.3g} rad; {d1:.6g}, {d2:.6g} rad s⁻¹)"
        for key, what in (("floquet_step", "fixed point of floquet step"),
                          ("refine_step", "start of refine step")):
            if ds.attrs.get(key):
                return f"{s}, {what} {ds.attrs[key]}"
        return s
    s = f"gait ({d1:.6g}, {d2:.6g}) rad s⁻¹"
    src = ds.attrs.get("shoot_step")
    return f"{s} from shoot step {src}" if src else s


def times_of(ds) -> str:
    ts, tm = attr_float(ds, "t_switch"), attr_float(ds, "t_motor")
    if not math.isfinite(ts):
        return ""
    s = f"swap at {ts:.4g} s"
    if math.isfinite(tm):
        s += ", no motor phase" if tm == 0 else f", motor {tm:.4g} s"
    return s


def visible_len(word: str) -> int:
    """Characters ``word`` shows once drawn (mathtext ``$...$`` counted by its glyphs)."""
    def glyphs(m):
        inner = re.sub(r"\\[a-zA-Z]+", "x", m.group(0)[1:-1])
        return "x" * len(re.sub(r"[{}^_]", "", inner))
    return len(re.sub(r"\$[^$]*\$", glyphs, word))


def wrap_text(text: str, width: int) -> str:
    """Greedy word wrap of each line of ``text`` to ``width`` visible characters; a word
    longer than a line (a step name of 100 characters) is cut into lines of ``width``."""
    out = []
    for line in text.split("\n"):
        cur, n = [], 0
        for w in line.split(" "):
            k = visible_len(w)
            while k > width and "$" not in w:
                if cur:
                    out.append(" ".join(cur))
                    cur, n = [], 0
                out.append(w[:width])
                w = w[width:]
                k = len(w)
            if cur and n + 1 + k > width:
                out.append(" ".join(cur))
                cur, n = [], 0
            n += k + (1 if cur else 0)
            cur.append(w)
        out.append(" ".join(cur))
    return "\n".join(out)


def two_titles(fig, title: str, subtitle: str):
    """Bold title and a smaller subtitle (what was run) above every panel, wrapped to the
    figure's width; returns the subfigure the panels go in."""
    usable = fig.get_figwidth() * 72.0 * 0.93          # [pt]
    fig.suptitle(wrap_text(title, int(usable / 6.9)), x=0.02, ha="left", fontweight="bold")
    body = fig.subfigures(1, 1)
    body.suptitle(wrap_text(subtitle, int(usable / 4.8)), x=0.02, ha="left", **SUB)
    return body


def sci(x: float, digits: int = 2) -> str:
    """Short scientific text: ``4.9e-27``; ``0``; ``nan`` as a dash."""
    if not math.isfinite(x):
        return "–"
    if x == 0:
        return "0"
    return f"{x:.{digits - 1}e}".replace("e-0", "e-").replace("e+0", "e+")


def duration(seconds: float) -> str:
    """A duration as a person reads it: ``31 ms`` below a second, ``2.69 s`` from one second
    up (three significant digits); ``–`` when it is not a number."""
    if not math.isfinite(seconds):
        return "–"
    if abs(seconds) < 1.0:
        return f"{seconds * 1e3:.3g} ms"
    return f"{seconds:.3g} s"


def positive(y) -> np.ndarray:
    """Values for a log axis: non-positive and non-finite ones masked."""
    y = np.asarray(y, float)
    return np.ma.masked_where(~np.isfinite(y) | (y <= 0), y)
