"""The robot itself, drawn from a stability dataset's trajectory (dim ``sample``).

* :func:`plot_filmstrip` - one gait cycle as a strip of frames: links as lines coloured by the
  controller stage (hanging from A, swap, motor on, hanging from B, ...), end A a filled
  circle, end B an open square, the attached end ringed; a timeline of the stages and the
  motor torque below.
* :func:`write_animation` - the whole multi-cycle run as an MP4 (ffmpeg, the imageio-ffmpeg
  wheel's), or a GIF without ffmpeg; made offline from the dataset, no simulation, its
  frames blitted and piped to the encoder.

Which end is attached is read from a ``flipped`` variable when the dataset has one, otherwise
from the trajectory itself: while swinging, the attached end is the one that does not move.
"""
from __future__ import annotations

import json
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.lines import Line2D
from matplotlib.path import Path as MarkerPath
from PIL import Image
from matplotlib.patches import Patch
from matplotlib.ticker import MaxNLocator

from .cycles import gait_text, own_controller, stop_note
from .drawing import NothingToDraw
from .labels import wrap_text
from .common import (
    BLUE, GREEN, ORANGE, PURPLE, VERMILLION, atomic_path, count, link_lengths, new_figure,
    run_label, style,
)

PHASE_SWING, PHASE_FLIGHT, PHASE_FIXED = 0, 1, 2

#: Controller stages as drawn: key -> (colour, legend text).
STAGES = {
    "A": (BLUE, "hanging from A, motor off"),
    "B": (GREEN, "hanging from B, motor off"),
    "A+motor": (VERMILLION, "hanging from A, motor on"),
    "B+motor": (ORANGE, "hanging from B, motor on"),     # told apart from A's in the legend
    "flight": (PURPLE, "free flight"),
    "fixed": ("0.45", "both ends attached"),
}
SWAP_COLOUR = "black"
#: a filmstrip's width [in]: at 150 dpi the study page (1100 px wide) shows it at 0.73 of its
#: size, its smallest text (7 pt) still 10.7 px high
FILMSTRIP_WIDTH = 10.0
END_A = dict(marker="o", ms=7, mfc="black", mec="black", ls="none")
END_B = dict(marker="s", ms=7, mfc="white", mec="black", mew=1.4, ls="none")
MAGNET = dict(marker="o", ms=14, mfc="none", mec="#B8860B", mew=2.0, ls="none")
#: a bar of a ladder, seen end on (its size is the marker's, not the bar's)
BAR = dict(marker="o", ms=7, mfc="0.55", mec="0.15", mew=1.0, ls="none")
#: the hook of the attached end over its bar: an arc over the bar's top, open below
HOOK = dict(marker=MarkerPath.arc(-35.0, 215.0), ms=17, mfc="none", mec="#B8860B", mew=2.4,
            ls="none")
#: a caught bar is where the new attached end sits after a swap, to this distance [m]: the
#: catch snaps it onto the bar, ``bar.dx``, ``bar.dy`` from the bar it leaves
BAR_TOLERANCE = 1e-6


@dataclass
class Trajectory:
    """The ``sample`` part of a stability dataset as numpy arrays."""

    t: np.ndarray        # [s]
    A: np.ndarray        # (n, 2) [m]
    joint: np.ndarray
    B: np.ndarray
    phase: np.ndarray    # int
    torque: np.ndarray   # [N m]
    attached: np.ndarray  # "A", "B", "none", "both"

    @property
    def stage(self) -> np.ndarray:
        """Stage key per sample (see :data:`STAGES`)."""
        names = {"none": "flight", "both": "fixed"}
        return np.array([names.get(a, a + "+motor" if m != 0 else a)
                         for a, m in zip(self.attached, self.torque)], dtype=object)

    def swaps(self) -> np.ndarray:
        """Sample indices right after the attached end changed from one end to the other."""
        a = self.attached
        return np.flatnonzero((a[1:] != a[:-1]) & np.isin(a[1:], ["A", "B"])
                              & np.isin(a[:-1], ["A", "B"])) + 1


def run_stages(traj: Trajectory) -> list[str]:
    """The stages (keys of :data:`STAGES`) the trajectory passes through, in that order."""
    seen = set(traj.stage)
    return [k for k in STAGES if k in seen]


def stage_handles(keys, *, patch: bool = False, lw: float = 3.0) -> list:
    """Legend entries of the stages ``keys``, in :data:`STAGES`' colours and words (the
    colours the robot is drawn in): bands (``patch``) or lines ``lw`` points wide."""
    if patch:
        return [Patch(color=STAGES[k][0], alpha=0.5, label=STAGES[k][1]) for k in keys]
    return [Line2D([], [], color=STAGES[k][0], lw=lw, label=STAGES[k][1]) for k in keys]


def has_trajectory(ds) -> bool:
    """Whether the dataset's layout holds a trajectory (its variables; it may be empty)."""
    return all(v in ds for v in ("A", "joint", "B"))


def require_samples(ds) -> None:
    """Raise :class:`NothingToDraw` when the trajectory has fewer than two samples."""
    n = ds.sizes.get("sample", 0)
    if n < 2:
        raise NothingToDraw("the run recorded no motion to draw ("
                            + ("no trajectory sample" if n == 0 else "a single sample")
                            + (f"; {stop_note(ds)}" if stop_note(ds) else "") + ")")


def trajectory(ds) -> Trajectory:
    """Read the trajectory of a stability dataset."""
    def xy(name):
        return np.asarray(ds[name].transpose("sample", "xy").values, float)

    t = np.asarray(ds["time"].values, float)
    A, joint, B = xy("A"), xy("joint"), xy("B")
    n = t.size
    phase = (np.asarray(ds["phase"].values, int) if "phase" in ds
             else np.full(n, PHASE_SWING))
    torque = (np.asarray(ds["motor_torque"].values, float) if "motor_torque" in ds
              else np.zeros(n))
    if "attached_end" in ds and ds["attached_end"].dims == ("sample",):
        swing_end = np.where(np.asarray(ds["attached_end"].values) != 0, "B", "A")
    else:
        swing_end = _stationary_end(t, A, B)
    attached = np.where(phase == PHASE_FLIGHT, "none",
                        np.where(phase == PHASE_FIXED, "both", swing_end))
    return Trajectory(t, A, joint, B, phase, torque, attached.astype(object))


def _stationary_end(t, A, B) -> np.ndarray:
    """Per sample, the end ("A"/"B") that does not move over the neighbouring interval.

    Intervals of zero length (a sample repeated at an impact) carry no information: a sample
    takes the interval after it if that has positive length, else the nearest one before it
    (else the nearest one after it).
    """
    n = t.size
    if n < 2:
        return np.array(["A"] * n, dtype=object)
    valid = np.diff(t) > 0
    dA = np.hypot(*np.diff(A, axis=0).T)
    dB = np.hypot(*np.diff(B, axis=0).T)
    cls = np.where(dA <= dB, "A", "B")
    k = np.arange(n - 1)
    before = np.maximum.accumulate(np.where(valid, k, -1))             # last valid <= k
    after = np.minimum.accumulate(np.where(valid, k, n)[::-1])[::-1]   # first valid >= k
    out = np.empty(n, dtype=object)
    for i in range(n):
        if i < n - 1 and valid[i]:
            j = i
        elif i > 0 and before[i - 1] >= 0:
            j = before[i - 1]
        else:
            j = after[min(i, n - 2)]
        out[i] = cls[j] if 0 <= j < n - 1 else "A"
    return out


def bar_offsets(ds) -> list[tuple[float, float]]:
    """The bars' offsets ``(dx, dy)`` [m] of the gait's ``until: bar`` segments (its ``gait``
    attribute; none for a gait without bar catches)."""
    try:
        gait = json.loads(ds.attrs.get("gait", "") or "null")
    except (TypeError, ValueError):
        return []
    if not isinstance(gait, dict):
        return []
    out = []
    for seg in gait.get("segments", []):
        bar = seg.get("bar") if isinstance(seg, dict) else None
        if seg.get("until") == "bar" and isinstance(bar, dict):
            out.append((float(bar.get("dx", 0.0)), float(bar.get("dy", 0.0))))
    return out


def ladder_bars(ds, traj: Trajectory) -> np.ndarray:
    """The bars of a run on a ladder, (n, 2) [m] in the world frame: the bar the robot
    starts from and each bar it caught, in the order reached (none, shape (0, 2), for a gait
    without bar catches).

    A swap is a catch when the new attached end sits one of the gait's bar offsets
    (:func:`bar_offsets`) from the end that held before it: the catch snaps the hook onto the
    bar (docs/model.md section 6), so the bar is where that end is after the swap.
    """
    offsets = np.array(bar_offsets(ds), float).reshape(-1, 2)
    if offsets.size == 0 or traj.t.size == 0:
        return np.zeros((0, 2))

    def held(i):
        return traj.B[i] if traj.attached[i] == "B" else traj.A[i]

    bars = [held(0)]
    for s in traj.swaps():
        step = held(s) - held(s - 1)
        if np.any(np.all(np.abs(offsets - step) <= BAR_TOLERANCE, axis=1)):
            bars.append(held(s))
    out = []
    for b in bars:
        if not any(np.all(np.abs(b - o) <= BAR_TOLERANCE) for o in out):
            out.append(b)
    return np.array(out, float).reshape(-1, 2)


def on_bar(pos, bars: np.ndarray) -> bool:
    """Whether ``pos`` [m] is on one of ``bars`` (:data:`BAR_TOLERANCE`)."""
    return bars.size > 0 and bool(np.any(np.all(np.abs(bars - pos) <= BAR_TOLERANCE,
                                                axis=1)))


def _cycle_bounds(ds, traj: Trajectory, cycle: int) -> tuple[int, int]:
    """Sample index range ``[i0, i1)`` of gait cycle ``cycle`` (1-based)."""
    t = traj.t
    if "t_cross" in ds and ds.sizes.get("cycle", 0) >= cycle:
        tc = np.asarray(ds["t_cross"].values, float)
        t0 = tc[cycle - 2] if cycle >= 2 else t[0]
        t1 = tc[cycle - 1]
        i0 = int(np.searchsorted(t, t0, side="left"))
        i1 = int(np.searchsorted(t, t1, side="right"))
        return i0, max(i1, i0 + 2)
    return 0, t.size


def _world_limits(traj: Trajectory, sl: slice, pad: float = 0.12):
    pts = np.concatenate([traj.A[sl], traj.joint[sl], traj.B[sl]])
    lo, hi = np.nanmin(pts, axis=0) - pad, np.nanmax(pts, axis=0) + pad
    return (lo[0], hi[0]), (lo[1], hi[1])


def _draw_pose(ax, traj: Trajectory, i: int, colour, *, labels: bool = False,
               gid: str = "pose", lw: float = 3.0, limits=None, bars: np.ndarray | None = None):
    xs = [traj.A[i, 0], traj.joint[i, 0], traj.B[i, 0]]
    ys = [traj.A[i, 1], traj.joint[i, 1], traj.B[i, 1]]
    line, = ax.plot(xs, ys, "-", color=colour, lw=lw, solid_capstyle="round", gid=gid,
                    zorder=4)
    ax.plot(*traj.joint[i], marker="o", ms=4, color="0.25", ls="none", zorder=5)
    a, = ax.plot(*traj.A[i], zorder=6, **END_A)
    b, = ax.plot(*traj.B[i], zorder=6, **END_B)
    att = traj.attached[i]
    for end, pos in (("A", traj.A[i]), ("B", traj.B[i])):
        if att in (end, "both"):
            if bars is not None and on_bar(pos, bars):
                ax.plot(*pos, zorder=7, gid="hook", **HOOK)
            else:
                ax.plot(*pos, zorder=3, **MAGNET)
    if labels:
        # each name on the side of its end toward the middle of the frame (``limits``: its
        # x and y ranges), so that it stays inside the frame
        (x0, x1), (y0, y1) = limits or ((-np.inf, np.inf), (-np.inf, np.inf))
        for name, pos in (("A", traj.A[i]), ("B", traj.B[i])):
            right = not pos[0] > (x0 + x1) / 2
            up = pos[1] < (y0 + y1) / 2
            ax.annotate(name, pos, xytext=(6 if right else -6, 4 if up else -4),
                        textcoords="offset points", fontsize=9, fontweight="bold", zorder=7,
                        ha="left" if right else "right", va="bottom" if up else "top",
                        gid=f"end_name_{name}")
    return line, a, b


#: frames closer in time than this show the same time in their titles (to the ms) [s]
SAME_TIME = 5e-4


def _pick_frames(traj: Trajectory, i0: int, i1: int, n_frames: int) -> list[int]:
    """``n_frames`` sample indices in ``[i0, i1)``: the first sample of every stage (start,
    swap, motor off, ...) and the last sample, the rest evenly spaced in time in between.
    Of key samples less than :data:`SAME_TIME` apart only the later is kept (a stage that
    begins at once: the start's pose, titled with the stage that follows)."""
    t = traj.t[i0:i1]
    st = traj.stage[i0:i1]
    keys = sorted({i0, i1 - 1} | {i0 + int(c) for c in np.flatnonzero(st[1:] != st[:-1]) + 1})
    apart = [k for k, after in zip(keys, keys[1:]) if traj.t[after] - traj.t[k] >= SAME_TIME]
    keys = set(apart + keys[-1:])
    n_even = max(n_frames - len(keys), 0)
    if n_even == 0:
        return sorted(keys)
    # spread the remaining frames over the gaps between key frames, by gap duration
    ks = sorted(keys)
    gaps = np.diff(traj.t[ks])
    share = np.floor(n_even * gaps / max(gaps.sum(), 1e-12)).astype(int)
    for k in np.argsort(-(n_even * gaps / max(gaps.sum(), 1e-12) - share))[:n_even - share.sum()]:
        share[k] += 1
    idx = set(ks)
    for (a, b), m in zip(zip(ks[:-1], ks[1:]), share):
        for x in np.linspace(traj.t[a], traj.t[b], m + 2)[1:-1]:
            j = i0 + int(np.argmin(np.abs(t - x)))
            if min(abs(traj.t[j] - traj.t[k]) for k in idx) >= SAME_TIME:
                idx.add(j)
    return sorted(idx)


def _change_tag(stage, i: int, swap: bool) -> str:
    """"swap", "motor on", "motor off" when sample ``i`` starts a new stage, else ""."""
    if swap:
        return "  swap" + (", motor on" if stage[i].endswith("+motor") else "")
    if i == 0 or stage[i] == stage[i - 1]:
        return ""
    if stage[i].endswith("+motor") and not stage[i - 1].endswith("+motor"):
        return "  motor on"
    if stage[i - 1].endswith("+motor") and not stage[i].endswith("+motor"):
        return "  motor off"
    return ""


# ----------------------------------------------------------------------------------------------
def plot_filmstrip(stab, *, cycle: int = 1, n_frames: int = 12, columns: int = 6,
                   gait=None):
    """One gait cycle of a stability run as a strip of frames (study fig. 2, from data).

    Each frame draws the robot at one sample: the links as a line coloured by the stage, end A
    a filled circle, end B an open square, the attached end ringed (magnet on). Frames are
    evenly spaced in time plus one at every stage change (swap, motor on/off). A timeline
    below shows the stages and the motor torque (in the motor frame for a gait whose study
    writes its torques so: attribute ``torque_frame``).

    Pose lines have ``gid`` ``pose``; their data are ``[A, joint, B]`` of a sample.
    """
    require_samples(stab)
    traj = trajectory(stab)
    i0, i1 = _cycle_bounds(stab, traj, cycle)
    frames = _pick_frames(traj, i0, i1, n_frames)
    stage = traj.stage
    xlim, ylim = _world_limits(traj, slice(i0, i1))
    bars = ladder_bars(stab, traj)
    n = len(frames)
    ncols = min(columns, n)
    nrows = int(np.ceil(n / ncols))
    span = max(xlim[1] - xlim[0], 1e-6)
    height = max(ylim[1] - ylim[0], 1e-6)
    panel_w = (FILMSTRIP_WIDTH - 0.5) / ncols
    with style():
        fig = new_figure(figsize=(FILMSTRIP_WIDTH, nrows * panel_w * height / span + 2.8))
        gs = fig.add_gridspec(nrows + 1, ncols, height_ratios=[1.0] * nrows + [0.55])
        swaps = set(traj.swaps())
        axes = []
        for k, i in enumerate(frames):
            ax = fig.add_subplot(gs[k // ncols, k % ncols],
                                 sharex=axes[0] if axes else None,
                                 sharey=axes[0] if axes else None)
            axes.append(ax)
            colour = STAGES.get(stage[i], ("0.3", ""))[0]
            # whole-cycle paths of the ends, faint, for orientation
            ax.plot(traj.A[i0:i1, 0], traj.A[i0:i1, 1], color="0.8", lw=0.8, zorder=1)
            ax.plot(traj.B[i0:i1, 0], traj.B[i0:i1, 1], color="0.8", lw=0.8, ls="--", zorder=1)
            ax.axhline(0.0, color="0.6", lw=0.6, ls=":", zorder=0)
            if bars.size:
                ax.plot(bars[:, 0], bars[:, 1], zorder=2, gid="bars", **BAR)
            _draw_pose(ax, traj, i, colour, labels=(k == 0), limits=(xlim, ylim),
                       bars=bars if bars.size else None)
            tag = _change_tag(stage, i, i in swaps)
            ax.set_title(f"{k + 1}: t = {traj.t[i]:.3f} s\n{tag.strip() or ' '}", fontsize=8.5,
                         fontweight="bold" if tag else "normal", color=colour, loc="center")
            ax.set_aspect("equal", adjustable="box")
            ax.tick_params(labelsize=7)
            ax.xaxis.set_major_locator(MaxNLocator(nbins=3))     # narrow panels
            if k % ncols != 0:
                ax.tick_params(labelleft=False)
            if k // ncols != nrows - 1 and k + ncols < n:
                ax.tick_params(labelbottom=False)
        axes[0].set_xlim(*xlim)
        axes[0].set_ylim(*ylim)
        axes[0].set_ylabel("y  [m]")
        if nrows > 1:
            axes[ncols].set_ylabel("y  [m]")
        for ax in axes[(nrows - 1) * ncols:]:
            ax.set_xlabel("x  [m]")
        # timeline: stages as coloured bands, torque as a step line, frame times as ticks
        tl = fig.add_subplot(gs[nrows, :])
        t = traj.t[i0:i1]
        st = stage[i0:i1]
        bounds = np.flatnonzero(st[1:] != st[:-1]) + 1
        starts = np.concatenate([[0], bounds])
        stops = np.concatenate([bounds, [len(t) - 1]])
        seen = []
        for a, b in zip(starts, stops):
            key = st[a]
            tl.axvspan(t[a], t[b], color=STAGES.get(key, ("0.3",))[0], alpha=0.25, lw=0)
            if key not in seen:
                seen.append(key)
        tl.plot(t, traj.torque[i0:i1], color="black", lw=1.2, drawstyle="steps-post",
                gid="torque")
        for s in sorted(swaps):
            if i0 <= s < i1:
                tl.axvline(traj.t[s], color=SWAP_COLOUR, lw=1.5, ls="--")
        for k, i in enumerate(frames):
            tl.annotate(str(k + 1), (traj.t[i], 0.97), xycoords=("data", "axes fraction"),
                        ha="center", va="top", fontsize=8, gid="frame_number",
                        bbox=dict(boxstyle="round,pad=0.12", fc="white", ec="none", alpha=0.8))
            tl.axvline(traj.t[i], ymin=0.8, ymax=0.86, color="0.3", lw=0.8)
        # room at both ends for the numbers of the first and last frames, centred on them
        margin = 0.025 * max(t[-1] - t[0], 1e-9)
        tl.set_xlim(t[0] - margin, t[-1] + margin)
        seg = traj.torque[i0:i1]
        tmax = max(float(np.nanmax(seg)) if i1 > i0 else 0.0, 0.0)
        tmin = min(float(np.nanmin(seg)) if i1 > i0 else 0.0, 0.0)
        span = max(tmax - tmin, 1e-3)
        # room above for the frame numbers; negative torques (a pulse the other way) shown
        tl.set_ylim(tmin - 0.1 * span, tmax + 0.45 * span)
        tl.set_xlabel("time  [s]")
        tl.set_ylabel("motor torque\n(motor frame)\n[N m]" if
                      stab.attrs.get("torque_frame") == "motor" else "motor torque\n[N m]")
        handles = stage_handles([k for k in STAGES if k in seen], patch=True)
        handles += [Line2D([], [], color=SWAP_COLOUR, ls="--",
                           label="catch (the hooks swap)" if bars.size else "magnet swap"),
                    Line2D([], [], label="end A", **END_A),
                    Line2D([], [], label="end B", **END_B),
                    *([Line2D([], [], label="bar (started from or caught)", **BAR),
                       Line2D([], [], label="hook on its bar (attached end)", **HOOK)]
                      if bars.size else
                      [Line2D([], [], label="attached end (magnet on)", **MAGNET)]),
                    Line2D([], [], color="0.8", lw=0.8, label="path of end A over the cycle"),
                    Line2D([], [], color="0.8", lw=0.8, ls="--",
                           label="path of end B over the cycle"),
                    Line2D([], [], color="0.6", lw=0.6, ls=":", label="start height")]
        fig.legend(handles=handles, loc="outside lower center", ncols=4, frameon=False)
        run = "run under the gait's own controller" if own_controller(stab) else "open-loop run"
        fig.suptitle(f"Gait cycle {cycle} of the {run}, "
                     f"{gait_text(stab, gait)}", x=0.01, ha="left", fontweight="bold")
        # wrapped: a long step name would run off the figure
        tl.set_title(wrap_text(run_label(stab), int(fig.get_figwidth() * 72 * 0.85 / 4.8)),
                     fontsize=8.5, fontweight="normal", loc="left")
    return fig


# ----------------------------------------------------------------------------------------------
def animation_frames(traj: Trajectory, fps: float, max_frames: int) -> tuple[np.ndarray, float]:
    """Sample indices of the frames and the playback speed-up (1 = real time)."""
    duration = float(traj.t[-1] - traj.t[0])
    n_real = int(duration * fps) + 1
    speed = max(1.0, n_real / max_frames)
    n = max(2, min(n_real, max_frames))
    times = traj.t[0] + np.linspace(0.0, duration, n)
    idx = np.searchsorted(traj.t, times, side="right") - 1
    return np.clip(idx, 0, traj.t.size - 1), speed


def ffmpeg_path() -> str | None:
    """The ffmpeg executable: the one the imageio-ffmpeg wheel ships, else one on the PATH;
    None when there is neither."""
    try:
        # imageio-ffmpeg locates its bundled binary on import: only animations need it
        import imageio_ffmpeg
        return imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError):
        return shutil.which("ffmpeg")


def animation_format() -> str:
    """``mp4`` when ffmpeg is available, else ``gif``."""
    return "mp4" if ffmpeg_path() is not None else "gif"


class Camera:
    """A view of fixed size that moves only when the robot would leave it.

    :meth:`follow` takes the box the view must hold: while the robot hangs from a magnet,
    every point it can swing to horizontally (the attached end +- its reach) and its actual
    height; in flight, where it is. The view keeps still while that box lies ``margin`` inside
    it; otherwise it jumps so that the box sits at its centre (vertically) or ``margin`` from
    its trailing edge (horizontally, travelling towards ``heading``, +1 or -1), which leaves
    the most room ahead. A still view lets the frames be blitted: the axes are redrawn only
    on a jump, a few times per run.
    """

    def __init__(self, width: float, height: float, margin: float, heading: float = 1.0):
        self.size = np.array([width, height], float)
        self.margin = float(margin)
        self.heading = 1.0 if heading >= 0 else -1.0
        self.lo: np.ndarray | None = None          # lower-left corner of the view [m]

    def follow(self, lo: np.ndarray, hi: np.ndarray) -> bool:
        """Move the view to hold the box ``lo``..``hi`` [m]; True when it moved."""
        centred = 0.5 * (lo + hi) - 0.5 * self.size
        if self.lo is None:
            self.lo = centred
            return True
        inside = (self.lo + self.margin <= lo) & (hi <= self.lo + self.size - self.margin)
        if inside.all():
            return False
        new = self.lo.copy()
        if not inside[0]:
            trailing = (lo[0] - self.margin if self.heading > 0
                        else hi[0] + self.margin - self.size[0])
            # a box wider than the view (a long robot in flight) is centred instead
            new[0] = trailing if hi[0] - lo[0] + 2 * self.margin <= self.size[0] \
                else centred[0]
        if not inside[1]:
            new[1] = centred[1]
        self.lo = new
        return True


class _FrameSink:
    """Where the frames go: ffmpeg's standard input (MP4) or a list of images (GIF)."""

    def __init__(self, fmt: str, path: Path, size: tuple[int, int], fps: float, comment: str,
                 title: str):
        self.fmt, self.path, self.size, self.fps = fmt, path, size, fps
        self.comment = comment
        self.images: list = []
        self.proc = None
        if fmt == "mp4":
            w, h = size
            cmd = [ffmpeg_path(), "-y", "-loglevel", "error", "-f", "rawvideo",
                   "-pix_fmt", "rgba", "-s", f"{w}x{h}", "-r", f"{fps:g}", "-i", "pipe:0",
                   "-vcodec", "h264", "-preset", "veryfast", "-pix_fmt", "yuv420p", "-metadata", f"comment={comment}",
                   "-metadata", f"title={title}", "-f", "mp4", str(path)]
            # its own session: Ctrl-C reaches the report, which stops the encoder itself
            self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stderr=subprocess.PIPE,
                                         start_new_session=True)

    def write(self, rgba) -> None:
        if self.proc is not None:
            self.proc.stdin.write(rgba)
        else:
            w, h = self.size
            self.images.append(Image.frombuffer("RGBA", (w, h), bytes(rgba), "raw", "RGBA", 0,
                                                1).convert("RGB"))

    def close(self) -> None:
        if self.proc is not None:
            self.proc.stdin.close()
            err = self.proc.stderr.read().decode(errors="replace")
            if self.proc.wait() != 0:
                raise RuntimeError(f"ffmpeg failed: {err.strip()}")
        else:
            self.images[0].save(self.path, format="GIF", save_all=True,
                                append_images=self.images[1:], duration=int(1000 / self.fps),
                                loop=0, comment=self.comment.encode("utf-8", "replace"))

    def abort(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait()


def first_cycles(stab, traj: Trajectory, cycles: int) -> Trajectory:
    """The trajectory up to the end of cycle ``cycles`` (its section crossing, ``t_cross``;
    the whole trajectory when the run has fewer cycles or no crossing times)."""
    if "t_cross" not in stab or stab.sizes.get("cycle", 0) < cycles or cycles < 1:
        return traj
    t_end = float(np.asarray(stab["t_cross"].values, float)[cycles - 1])
    if not np.isfinite(t_end):
        return traj
    n = int(np.searchsorted(traj.t, t_end, side="right"))
    return Trajectory(traj.t[:n], traj.A[:n], traj.joint[:n], traj.B[:n], traj.phase[:n],
                      traj.torque[:n], traj.attached[:n])


def write_animation(stab, base: Path, prov: dict, *, fps: float = 20.0, max_frames: int = 300,
                    dpi: float = 150.0, window: float | None = None, gait=None,
                    fmt: str | None = None, progress=None, cycles: int | None = None,
                    backdrop=None, view=None, title: str | None = None) -> list[Path]:
    """Animate the whole run of a stability dataset; write ``base.mp4`` (``base.gif`` when
    there is no ffmpeg, or with ``fmt="gif"``). The frames are 6.4 x 4 in at ``dpi``: 960 x
    600 pixels by default.

    Real time at ``fps`` frames per second unless that needs more than ``max_frames`` frames,
    then sped up (the speed-up is shown); the last frame is held for a second (with the reason
    when the run stopped early). The view, ``window`` metres wide (default 2.6 times the
    robot's reach), holds still and jumps only when the robot would leave it
    (:class:`Camera`), falling runs included, so the whole robot is always in view; the start
    height and the points where a magnet attached are drawn fixed in the world; on a ladder
    (a gait that catches bars, :func:`ladder_bars`) the bars instead, and the attached end's
    hook over its bar. ``cycles``: the first that many cycles only (:func:`first_cycles`).

    ``backdrop(ax)``, when given, draws what stands still behind the robot (a wall: its steel,
    holes, start and goal) on the axes once, before the frames, and returns the legend
    entries it wants (a list of artists, or None); the start-height line is then left out
    (the backdrop says where the robot starts). ``view``: fixed limits ``((x0, x1), (y0,
    y1))`` [m] instead of the moving camera (a whole wall in view). ``title``: the figure's
    title instead of the run and gait.

    The frames are drawn by blitting: the axes (ticks, grid, legend) are drawn once per view,
    and each frame only restores them and redraws the moving artists, whose pixels go straight
    to the encoder. ``progress(done, total)`` is called after each frame. Returns the written
    paths.
    """
    require_samples(stab)
    traj = trajectory(stab)
    bars = ladder_bars(stab, traj)
    if cycles is not None:
        traj = first_cycles(stab, traj, cycles)
    frames, speed = animation_frames(traj, fps, max_frames)
    stage = traj.stage
    lengths = link_lengths(stab) or (0.61, 0.61)
    reach = lengths[0] + lengths[1]
    swaps = traj.swaps()
    feet = np.array([traj.A[0]] + [traj.B[s] if traj.attached[s] == "B" else traj.A[s]
                                   for s in swaps]).reshape(-1, 2)
    foot_t = np.concatenate([[traj.t[0]], traj.t[swaps]])
    tc = np.asarray(stab["t_cross"].values, float) if "t_cross" in stab else np.zeros(0)
    comment = "; ".join(f"{k}={v}" for k, v in prov.items())
    fmt = fmt or animation_format()
    if fmt not in ("mp4", "gif"):
        raise ValueError(f"animation format must be mp4 or gif, got {fmt!r}")
    base = Path(base)
    path = base.with_name(f"{base.name}.{fmt}")
    stop = stop_note(stab) if cycles is None else None
    hold = max(1, int(round(fps)))
    total = len(frames) + hold
    with style():
        fig = new_figure(figsize=(6.4, 4.0), dpi=dpi, layout="none")
        fig.subplots_adjust(left=0.1, right=0.98, bottom=0.27, top=0.87)
        ax = fig.add_subplot()
        ax.set_aspect("equal", adjustable="box")
        behind = (backdrop(ax) or []) if backdrop is not None else None
        if backdrop is None:
            ax.axhline(0.0, color="0.5", lw=0.8, ls="--")
        trail, = ax.plot([], [], color="0.75", lw=0.8)
        foot, = ax.plot([], [], "v", color="#B8860B", ms=5, ls="none")
        line, = ax.plot([], [], "-", lw=4, solid_capstyle="round", zorder=4)
        jnt, = ax.plot([], [], "o", ms=4, color="0.25", zorder=5)
        a_m, = ax.plot([], [], zorder=6, **END_A)
        b_m, = ax.plot([], [], zorder=6, **END_B)
        if bars.size:
            # fixed in the world: drawn with the axes, under the moving robot
            ax.plot(bars[:, 0], bars[:, 1], zorder=2, gid="bars", **BAR)
            mag, = ax.plot([], [], zorder=7, gid="hook", **HOOK)
        else:
            mag, = ax.plot([], [], zorder=3, **MAGNET)
        # what is happening, under the axes: inside, it would cover the robot now and then
        info = fig.text(0.01, 0.015, "", fontsize=8, ha="left", va="bottom")
        moving = [trail, foot, mag, line, jnt, a_m, b_m, info]
        for artist in moving:
            artist.set_animated(True)
        ax.set_xlabel("x  [m]", labelpad=1)
        ax.set_ylabel("y  [m]")
        run = ("Run under the gait's own controller" if own_controller(stab)
               else "Open-loop run")
        fig.suptitle(title if title is not None else f"{run}, {gait_text(stab, gait)}",
                     fontsize=9, x=0.02, ha="left", fontweight="bold")
        shown = (f"; the first {count(cycles, 'cycle')}" if cycles is not None
                 and traj.t.size < stab.sizes.get("sample", 0) else "")
        ax.set_title(run_label(stab) + shown
                     + (f"; playback ×{speed:.1f}" if speed > 1 else ""),
                     fontsize=6.5, fontweight="normal", loc="left")
        held = ([Line2D([], [], label="bar", **BAR),
                 Line2D([], [], label="hook on its bar", **dict(HOOK, ms=11))] if bars.size
                else [Line2D([], [], label="magnet on", **dict(MAGNET, ms=9))])
        where = ([] if bars.size else
                 [Line2D([], [], marker="v", color="#B8860B", ms=5, ls="none",
                         label="a magnet attached here")])
        fig.legend(handles=stage_handles(run_stages(traj), lw=3)
                   + [Line2D([], [], label="end A", **END_A),
                      Line2D([], [], label="end B", **END_B)] + held
                   + ([Line2D([], [], color="0.5", lw=0.8, ls="--", label="start height")]
                      if behind is None else [])
                   + [Line2D([], [], color="0.75", lw=0.8, label="path of the joint")]
                   + where + (behind or []),
                   loc="lower center", bbox_to_anchor=(0.5, 0.055), ncols=4, fontsize=6,
                   frameon=False, columnspacing=1.2, handlelength=1.5, labelspacing=0.5)
        # the view, in metres, of the axes box's shape: it holds the robot's full swing
        # horizontally with room to travel, and its reach vertically
        box = ax.get_position(original=True)
        aspect = box.height * 4.0 / (box.width * 6.4)
        margin = 0.05 * reach
        width = window or max(2.9 * reach, (1.25 * reach + 2 * margin) / aspect)
        height = width * aspect
        heading = np.sign(feet[-1, 0] - feet[0, 0]) if feet.shape[0] > 1 else 1.0
        camera = Camera(width, height, margin=margin, heading=heading)
        canvas = fig.canvas
        background = None

        def draw_frame(i: int, final: bool = False):
            nonlocal background
            pts = np.array([traj.A[i], traj.joint[i], traj.B[i]])
            lo, hi = np.nanmin(pts, axis=0), np.nanmax(pts, axis=0)
            att = traj.attached[i]
            if att in ("A", "B"):           # all it can swing to, so the view need not chase it
                pivot = traj.B[i] if att == "B" else traj.A[i]
                lo[0], hi[0] = min(lo[0], pivot[0] - reach), max(hi[0], pivot[0] + reach)
            if view is not None:
                if background is None:
                    ax.set_xlim(*view[0])
                    ax.set_ylim(*view[1])
                    canvas.draw()
                    background = canvas.copy_from_bbox(fig.bbox)
            elif camera.follow(lo, hi) or background is None:
                ax.set_xlim(camera.lo[0], camera.lo[0] + width)
                ax.set_ylim(camera.lo[1], camera.lo[1] + height)
                canvas.draw()                       # everything but the moving artists
                background = canvas.copy_from_bbox(fig.bbox)
            colour = STAGES.get(stage[i], ("0.3", ""))[0]
            line.set_data(pts[:, 0], pts[:, 1])
            line.set_color(colour)
            jnt.set_data([traj.joint[i, 0]], [traj.joint[i, 1]])
            a_m.set_data([traj.A[i, 0]], [traj.A[i, 1]])
            b_m.set_data([traj.B[i, 0]], [traj.B[i, 1]])
            on = [q for e, q in (("A", traj.A[i]), ("B", traj.B[i])) if att in (e, "both")]
            mag.set_data([q[0] for q in on], [q[1] for q in on])
            k = np.searchsorted(foot_t, traj.t[i], side="right") if not bars.size else 0
            foot.set_data(feet[:k, 0], feet[:k, 1])
            j0 = max(0, i - 400)
            trail.set_data(traj.joint[j0:i + 1, 0], traj.joint[j0:i + 1, 1])
            cyc = (min(int(np.searchsorted(tc, traj.t[i], side="left")) + 1, tc.size)
                   if tc.size else None)
            text = (f"t = {traj.t[i]:.2f} s" + (f",  cycle {cyc}" if cyc else "")
                    + f":  {STAGES.get(stage[i], ('', stage[i]))[1]}")
            if final and stop:
                text, colour = stop, VERMILLION
            info.set_text(text)
            info.set_color(colour)
            canvas.restore_region(background)
            for artist in moving:
                fig.draw_artist(artist)
            return canvas.buffer_rgba()

        with atomic_path(path) as tmp:
            sink = _FrameSink(fmt, tmp, canvas.get_width_height(), fps, comment, base.name)
            try:
                done = 0
                for i in frames:
                    sink.write(draw_frame(int(i)))
                    done += 1
                    if progress:
                        progress(done, total)
                rgba = bytes(draw_frame(int(frames[-1]), final=True))   # held for a second
                for _ in range(hold):
                    sink.write(rgba)
                    done += 1
                    if progress:
                        progress(done, total)
                sink.close()
            finally:
                sink.abort()
    return [path]
