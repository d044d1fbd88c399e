"""Shared plumbing of the figure functions: style, run descriptions, provenance, saving.

Figures are built with the matplotlib object API (:class:`matplotlib.figure.Figure` with an Agg
canvas, never pyplot state) inside :func:`style`, the context of the one style file shipped in
the package (``monkeystudy/monkeystudy.mplstyle``).
"""
from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
from importlib import resources
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import matplotlib
import matplotlib.style
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogFormatterSciNotation

import monkeystudy
from ..robot import Robot
from ..study.progress import all_of, count   # re-exported: the figures word counts as the log does
from ..simulation import STATUS_NAMES

#: The package's style file.
STYLE_FILE = Path(str(resources.files("monkeystudy") / "monkeystudy.mplstyle"))

#: Okabe-Ito colours used by name across the figures.
BLUE, VERMILLION, GREEN, PURPLE, ORANGE, SKY, YELLOW, BLACK = (
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#F0E442", "#000000")
MINIMUM_COLOUR = "#39d353"      # the study marks its minima with green squares (fig. 4)
#: units of the gait error e: theta2_f^2 [rad2] plus two squared rate differences [rad2 s-2],
#: a sum of mixed units as the 2009 study defines it (docs/model.md)
ERROR_UNITS = "[rad² + rad² s⁻²]"
#: the width of the study page's column [px] (:mod:`.page`): a wider figure is shown scaled
#: down to it
PAGE_WIDTH_PX = 1100


def style():
    """Context manager applying the package style (use around creating and saving)."""
    return matplotlib.style.context(str(STYLE_FILE))


def new_figure(**kwargs) -> Figure:
    """A pyplot-free figure with an Agg canvas attached."""
    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


# ----------------------------------------------------------------------------------------------
# reading dataset attributes
# ----------------------------------------------------------------------------------------------
def json_attr(ds, name: str, default=None):
    """A JSON-valued global attribute as Python data (``default`` when absent or not JSON)."""
    raw = ds.attrs.get(name)
    if raw is None:
        return default
    if isinstance(raw, (dict, list)):
        return raw
    try:
        return json.loads(raw)
    except (TypeError, ValueError):
        return raw if default is None else default


def robot_name(ds) -> str:
    r = json_attr(ds, "robot")
    if isinstance(r, dict):
        return str(r.get("name") or r.get("preset") or "custom robot")
    return str(r) if r else "robot ?"


def link_lengths(ds) -> tuple[float, float] | None:
    """``(L1, L2)`` [m] from the ``robot`` attribute, or None."""
    r = json_attr(ds, "robot")
    try:
        return float(r["link1"]["length"]), float(r["link2"]["length"])
    except (TypeError, KeyError, ValueError):
        return None


def robot_object(ds):
    """The :class:`monkeystudy.Robot` described by the ``robot`` attribute, or None."""
    r = json_attr(ds, "robot")
    if not isinstance(r, dict):
        return None
    try:
        return Robot.from_dict(r)
    except (TypeError, KeyError, ValueError):
        return None


def gait_settings(ds) -> dict:
    g = json_attr(ds, "gait", {})
    return g if isinstance(g, dict) else {}


def fmt_tick(tick) -> str:
    try:
        tick = float(tick)
    except (TypeError, ValueError):
        return "tick ?"
    if tick == 0:
        return "exact event timing"
    return f"{tick * 1e3:g} ms tick"


def run_label(ds, step: bool = True) -> str:
    """One line saying what was run: robot, torque, controller tick (the run's own, a
    ``controller`` attribute's, else the gait's), integrator, study (and step unless
    ``step`` is false)."""
    g = gait_settings(ds)
    parts = [f"robot {robot_name(ds)}"]
    if "motor_torque" in g:
        parts.append(f"τ = {float(g['motor_torque']):g} N m")
    controller = json_attr(ds, "controller", {})
    if isinstance(controller, dict) and "tick" in controller:
        parts.append(fmt_tick(controller["tick"]))
    elif "tick" in g:
        parts.append(fmt_tick(g["tick"]))
    integ = json_attr(ds, "integrator", {})
    if isinstance(integ, dict) and "method" in integ:
        s = str(integ["method"]).upper()
        if "rtol" in integ:
            s += f" rtol {float(integ['rtol']):.0e}"
        parts.append(s)
    study = ds.attrs.get("study_name")
    step_name = ds.attrs.get("step_name") if step else None
    if study or step_name:
        parts.append(f"study {study or '?'}" + (f" / {step_name}" if step_name else ""))
    return ", ".join(parts)


def status_name(code: int) -> str:
    code = int(code)
    return STATUS_NAMES[code] if 0 <= code < len(STATUS_NAMES) else f"status {code}"


def provenance(datasets: Sequence, inputs: Iterable[Path] = ()) -> dict[str, str]:
    """Provenance strings of a figure drawn from ``datasets`` (read from their attributes)."""
    def joined(name):
        vals = []
        for ds in datasets:
            v = ds.attrs.get(name)
            if v is not None and str(v) not in vals:
                vals.append(str(v))
        return ", ".join(vals) if vals else "unknown"

    return {
        "study_name": joined("study_name"),
        "study_sha256": joined("study_sha256"),
        "monkeystudy_version": joined("monkeystudy_version"),
        "git_revision": joined("git_revision"),
        "plotting_version": monkeystudy.__version__,
        "inputs": ", ".join(Path(p).name for p in inputs),
    }


# ----------------------------------------------------------------------------------------------
# saving
# ----------------------------------------------------------------------------------------------
def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _current_umask()


def _atomic_target(path: Path):
    """A temporary file beside ``path`` with the same suffix (for an os.replace)."""
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    return Path(tmp)


@contextlib.contextmanager
def atomic_path(path: Path):
    """Yield a temporary path; on success it replaces ``path`` atomically."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _atomic_target(path)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_UMASK)      # mkstemp makes 0600; give the usual mode
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def save_figure(fig: Figure, base: Path, prov: Mapping[str, str], *,
                formats: Sequence[str] = ("png", "pdf"), title: str = "") -> list[Path]:
    """Write ``fig`` as ``base.<fmt>`` for each format with provenance in the file metadata.

    PNG: text chunks ``Title``, ``Software``, ``Source`` and one per provenance key.
    PDF: the standard info keys (``Title``, ``Subject``, ``Keywords``, ``Creator``); no
    creation date, so an unchanged figure gives an identical file.
    """
    base = Path(base)
    keywords = "; ".join(f"{k}={v}" for k, v in prov.items())
    software = f"monkeystudy {monkeystudy.__version__} (matplotlib {matplotlib.__version__})"
    written = []
    for fmt in formats:
        path = base.with_name(f"{base.name}.{fmt}")
        if fmt == "png":
            meta = {"Title": title or base.name, "Software": software, "Source": keywords}
            meta.update({k: str(v) for k, v in prov.items()})
        elif fmt == "pdf":
            meta = {"Title": title or base.name, "Subject": keywords, "Keywords": keywords,
                    "Creator": software, "CreationDate": None}
        else:
            meta = None
        with style(), atomic_path(path) as tmp:
            fig.savefig(tmp, format=fmt, metadata=meta)
        written.append(path)
        if fig.get_layout_engine() is not None:
            fig.set_layout_engine("none")   # laid out once: later formats keep the positions
    return written


def finite(x) -> bool:
    """Whether ``x`` is a finite number (text of a non-finite value says nothing)."""
    try:
        return math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


def plain_log_labels(axis) -> None:
    """Label a logarithmic axis with plain numbers (``4``, ``0.002``), minor ticks too, so that
    a range shorter than a decade reads ``4 5 6``, not ``4×10⁰ 5×10⁰ 6×10⁰``."""
    def fmt(v, _pos):
        return f"{v:g}"
    axis.set_major_formatter(FuncFormatter(fmt))
    axis.set_minor_formatter(FuncFormatter(
        lambda v, pos: fmt(v, pos) if _short_range(axis) else ""))


def _short_range(axis) -> bool:
    lo, hi = sorted(axis.get_view_interval())
    return lo > 0 and hi / lo < 10.0


def readable_log_axis(ax, which: str = "y") -> None:
    """Give a log axis of ``ax`` (``"x"`` or ``"y"``, its data drawn) enough labelled ticks:
    a view shorter than a decade ends on one-digit multiples of its decade (``1e-4`` to
    ``9e-4``, not a view between two labelled ticks) and labels every minor tick; a view with
    fewer than two powers of ten in it labels some minor ticks too."""
    axis = ax.yaxis if which == "y" else ax.xaxis
    get, put = (ax.get_ylim, ax.set_ylim) if which == "y" else (ax.get_xlim, ax.set_xlim)
    lo, hi = sorted(get())
    if axis.get_scale() != "log" or not (0 < lo < hi) or not math.isfinite(hi):
        return
    powers = math.floor(math.log10(hi)) - math.ceil(math.log10(lo)) + 1
    if powers >= 2:
        return
    if hi / lo < 10.0:
        scale = 10.0 ** math.floor(math.log10(lo))
        lo = math.floor(lo / scale * (1 + 1e-12)) * scale
        scale = 10.0 ** math.floor(math.log10(hi))
        hi = math.ceil(hi / scale * (1 - 1e-12)) * scale
        put(lo, hi)
    # minor ticks: every one labelled within a decade, a subset over one to two decades
    axis.set_minor_formatter(LogFormatterSciNotation(labelOnlyBase=False,
                                                     minor_thresholds=(math.inf, 1.0)))


def finite_or_nan(x) -> float:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return math.nan
    return x


def as_float_array(da) -> np.ndarray:
    return np.asarray(da.values if hasattr(da, "values") else da, dtype=float)
