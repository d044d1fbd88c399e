"""Controllers as data: each one compiles to a program table the hybrid kernel runs.

* :class:`HorizontalSearch` - the study's state-based search controller (docs/model.md section 4):
  swap when the free end rises to the attached end's height, motor on with torque ``tau``
  until the gait-start energy is restored, stop when link 1 passes the vertical.
* :class:`OpenLoop` - the time-based controller that replays recorded times (swap at ``t_switch``,
  motor for ``t_motor``), the clock restarting at each vertical crossing or running on with a
  period.
* :class:`PhaseSequence` - any sequence of :class:`Segment` rows (multi-swing, flight, climbing
  gaits) without new kernel code.
* :class:`SequenceGait` - a phase sequence closed into a gait cycle by a Poincare section
  (link 1 crossing ``theta1 = c`` in the frame of the attached end): the gait every study step
  searches, replays and analyses. :func:`horizontal_gait` is the study's horizontal gait as
  one (``gait: {kind: horizontal}`` in a study file).

Every controller has a ``tick`` [s]: 0 acts exactly at events; ``0.001`` is the study's loop.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from .kernel import layout as L
from .kernel.integrate import method_scalar

GUARD_KINDS = {
    "none": L.G_NONE, "time": L.G_TIME, "free_end_height": L.G_FREE_END_HEIGHT,
    "energy_restored": L.G_ENERGY_RESTORED, "coord": L.G_COORD, "energy": L.G_ENERGY,
    "free_end_y": L.G_FREE_END_Y, "bar": L.G_BAR,
}
#: a coord guard's coordinate: its name in programs and study files, and its slot in the
#: kernel's full state (layout ``X`` .. ``DTH2``)
COORD_INDEX = {"x": L.X, "y": L.Y, "theta1": L.TH1, "theta2": L.TH2, "dx": L.DX, "dy": L.DY,
               "dtheta1": L.DTH1, "dtheta2": L.DTH2}
DIRECTIONS = {"rising": 1.0, "falling": -1.0, "either": 0.0}


@dataclass(frozen=True)
class Segment:
    """One row of a phase-sequence program.

    Parameters
    ----------
    until : str
        Guard ending the segment: ``time`` (``value`` on the controller clock [s]),
        ``free_end_height`` (the free end ``value`` [m] above the attached end; 0: at its
        height), ``energy_restored`` (energy back to the latched reference plus ``value``
        [J]), ``coord`` (``coord`` crosses ``value``),
        ``energy`` (total energy crosses ``value`` [J]), ``free_end_y`` (the free end's world
        height crosses ``value`` [m]), ``bar`` (a catch on a bar ``value`` [m] above and
        ``bar_dx`` [m] ahead of the attached end: the free end comes down through the bar's
        height within ``bar_window`` [m] of it horizontally; docs/model.md section 6), or
        ``none`` (only the horizon ends it).
    bar_dx, bar_window : float
        A ``bar`` guard's bar: its horizontal offset from the attached end, world x, signed
        by the direction of travel [m], and the largest horizontal distance of the free end
        from it at which the hook catches it [m] (> 0). A catch is never on a controller
        tick and has no delay.
    magnets : str
        Entry action: ``keep``, ``swap``, ``A``, ``B``, ``both`` or ``none`` (which ends are on).
    torque : float
        Motor torque from entry on [N m], on theta2 of the frame after the entry action.
    delay : float
        The exit (and the next row's entry actions) comes this long after the guard fires
        [s]: a time guard's instant moves by it (either sign); a state guard's action waits
        for it (>= 0, an actuation latency). Survival runs set it per cycle (timing jitter).
    """

    until: str
    value: float = 0.0
    coord: str = "theta1"
    direction: str = "rising"
    magnets: str = "keep"
    torque: float = 0.0
    latch_energy: bool = False
    ticked: bool = True
    clock: str = "keep"          # keep | reset (origin = exit time) | advance (origin += value)
    cycle_end: bool = False
    next: int | None = None      # default: the following row; -1 stops
    fail_status: int = L.ST_HORIZON
    delay: float = 0.0
    bar_dx: float = 0.0
    bar_window: float = 0.0

    def row(self, index: int, n_rows: int) -> np.ndarray:
        r = np.zeros(L.N_SEG_COLS)
        mags = {"keep": (-1, -1, 0), "swap": (-1, -1, 1), "A": (1, 0, 0), "B": (0, 1, 0),
                "both": (1, 1, 0), "none": (0, 0, 0)}
        if self.magnets not in mags:
            raise ValueError(f"segment {index}: magnets must be one of {sorted(mags)}, "
                             f"got {self.magnets!r}")
        if self.until not in GUARD_KINDS:
            raise ValueError(f"segment {index}: until must be one of {sorted(GUARD_KINDS)}, "
                             f"got {self.until!r}")
        if self.direction not in DIRECTIONS:
            raise ValueError(f"segment {index}: direction must be one of {sorted(DIRECTIONS)}")
        if self.coord not in COORD_INDEX:
            raise ValueError(f"segment {index}: coord must be one of {sorted(COORD_INDEX)}")
        if not (math.isfinite(self.value) and math.isfinite(self.torque)
                and math.isfinite(self.delay)):
            raise ValueError(f"segment {index}: value, torque and delay must be finite")
        if self.delay < 0 and self.until != "time":
            raise ValueError(f"segment {index}: a state guard's delay is a latency, >= 0 "
                             f"(got {self.delay!r})")
        if self.until == "bar":
            if not (math.isfinite(self.bar_dx) and math.isfinite(self.bar_window)
                    and self.bar_window > 0.0):
                raise ValueError(f"segment {index}: a bar guard needs a finite bar_dx and a "
                                 f"bar_window > 0 [m] (got {self.bar_dx!r}, "
                                 f"{self.bar_window!r})")
            if self.direction != "falling":
                raise ValueError(f"segment {index}: a bar guard is falling (the hook comes "
                                 f"down onto the bar), got {self.direction!r}")
            if self.delay != 0.0:
                raise ValueError(f"segment {index}: a bar guard has no delay (the hook "
                                 f"catches when it meets the bar), got {self.delay!r}")
        r[L.S_MAG_A], r[L.S_MAG_B], r[L.S_SWAP] = mags[self.magnets]
        r[L.S_TORQUE] = self.torque
        r[L.S_SET_EREF] = 1.0 if self.latch_energy else 0.0
        r[L.S_GUARD] = GUARD_KINDS[self.until]
        r[L.S_GINDEX] = COORD_INDEX[self.coord]
        r[L.S_GVALUE] = self.value
        r[L.S_GDIR] = DIRECTIONS[self.direction]
        # a catch is physical: never on the controller's tick
        r[L.S_TICKED] = 1.0 if self.ticked and self.until != "bar" else 0.0
        nxt = index + 1 if self.next is None else self.next
        r[L.S_NEXT] = nxt if nxt < n_rows else -1
        r[L.S_CLOCK] = {"keep": 0, "reset": 1, "advance": 2}[self.clock]
        r[L.S_FAIL] = self.fail_status
        r[L.S_CYCLE] = 1.0 if self.cycle_end else 0.0
        r[L.S_DELAY] = self.delay
        if self.until == "bar":
            r[L.S_BAR_DX] = self.bar_dx
            r[L.S_BAR_WINDOW] = self.bar_window
        return r


@dataclass(frozen=True)
class Observer:
    """A guard whose crossings are logged without changing the run (e.g. the vertical)."""

    until: str = "coord"
    coord: str = "theta1"
    value: float = 0.0
    direction: str = "either"
    segment: int = -1   # watch only in this program row (-1: always)

    def row(self) -> np.ndarray:
        if self.until == "bar":
            raise ValueError("an observer cannot watch a bar: a catch is a segment's guard")
        r = np.zeros(L.N_OBS_COLS)
        r[L.O_GUARD] = GUARD_KINDS[self.until]
        r[L.O_GINDEX] = COORD_INDEX[self.coord]
        r[L.O_GVALUE] = self.value
        r[L.O_GDIR] = DIRECTIONS[self.direction]
        r[L.O_SEGMENT] = self.segment
        return r


#: Link 1 passing the vertical, in either direction, at any time.
VERTICAL = Observer("coord", "theta1", 0.0, "either")
#: The vertical crossing that ends a gait cycle: watched only in the gaits' last segment (after
#: the motor phase), so a mid-swing pass of link 1 back through the vertical is not mistaken
#: for the end of a cycle.
CYCLE_VERTICAL = Observer("coord", "theta1", 0.0, "either", segment=2)


@dataclass(frozen=True)
class PhaseSequence:
    """A controller given directly as its segments (and observers).

    ``rise`` [m per cycle]: the route's planned height rises by this at each completed cycle
    (every row's cycle-ending exit counts): in a run's cycle ``k`` (from 0) a ``free_end_y``
    guard targets ``value + k * rise``, and a fall (``max_drop``) is measured from the
    start's height plus ``k * rise`` (docs/model.md section 6).
    """

    segments: Sequence[Segment]
    observers: Sequence[Observer] = (VERTICAL,)
    tick: float = 0.0
    tick_phase: float = 0.0
    rise: float = 0.0

    def program(self) -> tuple[np.ndarray, np.ndarray]:
        n = len(self.segments)
        if n == 0:
            raise ValueError("a phase sequence needs at least one segment")
        if not math.isfinite(self.rise):
            raise ValueError(f"rise must be finite, got {self.rise!r}")
        prog = np.stack([s.row(i, n) for i, s in enumerate(self.segments)])
        prog[:, L.S_RISE] = self.rise
        obs = (np.stack([o.row() for o in self.observers]) if self.observers
               else np.zeros((0, L.N_OBS_COLS)))
        return prog, obs


def _check_tick(tick: float) -> float:
    tick = float(tick)
    if not math.isfinite(tick) or tick < 0.0:
        raise ValueError(f"tick must be finite and >= 0, got {tick!r}")
    return tick


@dataclass(frozen=True)
class HorizontalSearch:
    """The study's state-based search controller (docs/model.md section 4, steps 1-4).

    ``torque`` [N m] is signed, on theta2 of the new attachment frame. With ``cycles`` > 1 the
    program loops (each cycle latches its own start energy).
    """

    torque: float
    tick: float = 0.0
    tick_phase: float = 0.0
    loop: bool = False

    def __post_init__(self):
        _check_tick(self.tick)
        if not math.isfinite(self.torque):
            raise ValueError(f"torque must be finite, got {self.torque!r}")

    def segments(self) -> list[Segment]:
        return [
            Segment("free_end_height", direction="rising", latch_energy=True,
                    fail_status=L.ST_NO_SWITCH),
            Segment("energy_restored", direction="rising", magnets="swap", torque=self.torque,
                    fail_status=L.ST_ENERGY_NOT_RESTORED),
            # the end of the gait is an observation, not an actuation: exact, never ticked
            Segment("coord", coord="theta1", value=0.0, direction="either", ticked=False,
                    cycle_end=True, next=0 if self.loop else -1,
                    fail_status=L.ST_NO_RETURN),
        ]

    def program(self):
        return PhaseSequence(self.segments(), (CYCLE_VERTICAL,) if self.loop else (),
                             self.tick, self.tick_phase).program()


#: Clock modes of :class:`OpenLoop`.
CLOCK_MODES = ("reset_at_vertical", "run_on")


@dataclass(frozen=True)
class OpenLoop:
    """Time-based open-loop controller replaying a gait's recorded times (docs/model.md section 4).

    Each cycle: swap at ``t_switch`` on the controller clock with motor torque ``torque``,
    motor off at ``t_switch + t_motor``. With ``clock="reset_at_vertical"`` the clock restarts
    when link 1 passes the vertical (on a tick, when ticked); with ``"run_on"`` it advances by
    ``period`` [s] each cycle and never looks at the state.
    """

    t_switch: float
    t_motor: float
    torque: float
    tick: float = 0.0
    tick_phase: float = 0.0
    clock: str = "reset_at_vertical"
    period: float = math.nan

    def __post_init__(self):
        _check_tick(self.tick)
        for name in ("t_switch", "t_motor"):
            v = getattr(self, name)
            if not math.isfinite(v) or v < 0:
                raise ValueError(f"{name} must be finite and >= 0, got {v!r}")
        if self.clock not in CLOCK_MODES:
            raise ValueError(f"clock must be one of {CLOCK_MODES}, got {self.clock!r}")
        if self.clock == "run_on" and not (math.isfinite(self.period) and
                                           self.period > self.t_switch + self.t_motor):
            raise ValueError("period must be finite and longer than t_switch + t_motor "
                             f"for clock='run_on', got {self.period!r}")

    def segments(self) -> list[Segment]:
        segs = [
            Segment("time", value=self.t_switch, fail_status=L.ST_NO_SWITCH),
            Segment("time", value=self.t_switch + self.t_motor, magnets="swap",
                    torque=self.torque, fail_status=L.ST_ENERGY_NOT_RESTORED),
        ]
        if self.clock == "reset_at_vertical":
            segs.append(Segment("coord", coord="theta1", value=0.0, direction="either",
                                clock="reset", cycle_end=True, next=0,
                                fail_status=L.ST_NO_RETURN))
        else:
            segs.append(Segment("time", value=self.period, clock="advance", cycle_end=True,
                                next=0))
        return segs

    def program(self):
        return PhaseSequence(self.segments(), (CYCLE_VERTICAL,), self.tick,
                             self.tick_phase).program()


#: a magnet action in the mirror image of a cycle (ends A and B exchanged); the others are
#: their own mirror images
MIRRORED_MAGNETS = {"A": "B", "B": "A"}


def _rows_before_magnets(rows: Sequence[Segment]) -> list[int]:
    """Rows of a looping program whose exit enters a row that acts on the magnets (the row
    after the last is the first)."""
    n = len(rows)
    return [k for k in range(n) if rows[(k + 1) % n].magnets != "keep"]


#: which ends each ``magnets`` entry action leaves attached, from the ends attached before
def _attached_after(magnets: str, before: frozenset) -> frozenset:
    if magnets == "keep":
        return before
    if magnets == "swap":
        return frozenset({"A", "B"} - before) if len(before) == 1 else before
    return {"A": frozenset("A"), "B": frozenset("B"), "both": frozenset("AB"),
            "none": frozenset()}[magnets]


@dataclass(frozen=True)
class SequenceGait:
    """A gait cycle given as phase-sequence segments, closed by a Poincare section.

    A cycle starts on the section hanging from end A at the origin, with link 1 at
    ``section_theta1`` [rad], link 2 at ``theta2`` [rad] and the rates being searched; it runs
    ``segments`` in order, then a last segment (motor torque ``section_torque`` [N m]) that
    ends the cycle when link 1 crosses ``section_theta1`` in ``section_direction``, in the
    frame of the end attached then. The controller clock restarts at the section, so time
    guards count from the cycle start. The section error generalises docs/model.md section 4:
    ``wrap(theta2_f - theta2)^2 + (dtheta1_f - dtheta1)^2 + (dtheta2_f - dtheta2)^2``.

    With a finite ``period`` [s] the clock runs on instead: the cycle ends when the clock
    reaches ``period`` (no sensed event), the clock advances by it, and the section is clock
    phase zero, where the state is ``(theta1, theta2, dtheta1, dtheta2)`` (the error adds
    ``(theta1_f - theta1)^2``). ``section_theta1`` is then only the start's ``theta1``.

    Attributes
    ----------
    wrap_theta2 : bool
        The section error wraps ``theta2_f - theta2`` to [-pi, pi) [rad] (a link 2 that
        turned a whole revolution is the same gait). False: the 2009 study's error, with the
        difference as it is.
    unreachable_below_floor : bool
        A start whose total energy is below the robot's swap energy floor [J]
        (:meth:`~monkeystudy.Robot.swap_energy_floor`) is marked ``unreachable`` by the
        one-cycle evaluation without integrating it. Only for a gait whose first segment
        swings freely up to the free end's height (:meth:`starts_by_free_swing`): energy
        cannot grow before that guard, so the start provably never reaches it.
    section_ticked : bool
        The section acts on the controller tick: the cycle ends, and the clock restarts (or
        advances), at the first tick after the crossing (or the period). Default exact.
    open_loop_section_ticked : bool
        The open-loop replay (:func:`~monkeystudy.analysis.replay.open_loop_gait`) senses
        the section on the tick (``section_ticked`` there): the 2009 study's controller
        restarted its clock on its 1 ms loop. The gait's own controller keeps its section.
    rise : float
        The route's planned height rises by this per cycle [m] (< 0: it descends): the world
        heights the ``free_end_y`` guards name are those of the cycle from the start; in a
        run's cycle ``k`` (from 0) each is ``k * rise`` higher, a staircase fixed in the
        world, so a catch late in one step is corrected in the next. The full map
        (:func:`~monkeystudy.analysis.cycle_full_map`) measures the height from this
        staircase, and a run's fall and a survival run's height drift from its planned
        height. The mirror image of an alternating cycle rises by the same. 0: the heights
        are the same every cycle.
    records : {"section", "swap"}
        Where a multi-cycle run records each cycle (:func:`~monkeystudy.analysis.replay.
        sequence_cycles`): at its section crossing (the attached end there), or from its
        swap (the attached end just after the swap, the error at the first section crossing
        after it: the 2009 study's figures 5-7, also right for a clock that runs on, which
        may pass the section twice or not at all in a cycle). ``'swap'`` needs exactly one
        magnet action per cycle.
    """

    segments: Sequence[Segment]
    section_theta1: float = 0.0
    section_direction: str = "either"
    section_torque: float = 0.0
    theta2: float = 0.0
    tick: float = 0.0
    tick_phase: float = 0.0
    period: float = math.nan
    wrap_theta2: bool = True
    unreachable_below_floor: bool = False
    section_ticked: bool = False
    open_loop_section_ticked: bool = False
    records: str = "section"
    rise: float = 0.0

    def __post_init__(self):
        _check_tick(self.tick)
        if len(self.segments) == 0:
            raise ValueError("a sequence gait needs at least one segment before the section")
        if self.clocked and not self.period > 0.0:
            raise ValueError(f"period must be > 0 (or NaN: no running clock), got "
                             f"{self.period!r}")
        for name in ("section_theta1", "section_torque", "theta2", "tick_phase", "rise"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be finite, got {getattr(self, name)!r}")
        if self.section_direction not in DIRECTIONS:
            raise ValueError(f"section_direction must be one of {sorted(DIRECTIONS)}")
        if self.records not in RECORDS:
            raise ValueError(f"records must be one of {RECORDS}, got {self.records!r}")
        if self.unreachable_below_floor and not self.starts_by_free_swing():
            raise ValueError("unreachable_below_floor needs a first segment that swings "
                             "freely (magnets keep, no torque, no delay) until the free end "
                             "rises to the attached end's height: only then can a start "
                             "below the swap energy floor not reach it")
        if self.records == "swap" and len(self.magnet_rows()) != 1:
            raise ValueError("records='swap' needs exactly one magnet action per cycle, got "
                             f"{len(self.magnet_rows())}")
        self.end_attached()

    def starts_by_free_swing(self) -> bool:
        """The first segment swings freely (magnets kept, no torque, no delay) until the free
        end rises to the attached end's height (``free_end_height`` 0, rising): the energy
        of a start cannot grow before that guard fires."""
        s = self.segments[0]
        return (s.until == "free_end_height" and s.value == 0.0 and s.direction == "rising"
                and s.magnets == "keep" and s.torque == 0.0 and s.delay == 0.0)

    def magnet_rows(self) -> list[int]:
        """Rows of :meth:`all_segments` whose exit enters a segment that acts on the magnets
        (a swap, a catch, a release): where a cycle's magnet actions are logged."""
        return _rows_before_magnets(self.all_segments())

    @property
    def alternates(self) -> bool:
        """Each cycle runs as the mirror image of the one before, ends A and B exchanged: a
        cycle ends hanging from B, so the next starts hanging from B, and a magnet action
        names an end (``A`` or ``B``), which the next cycle names the other way (``keep``,
        ``swap``, ``both`` and ``none`` are their own mirror images). The return map compares
        the cycle's end in B's frame with its start in A's (mirror-image links,
        :func:`~monkeystudy.analysis.sections.check_cycle_frame`): it is the map of this
        alternation."""
        return (any(seg.magnets in MIRRORED_MAGNETS for seg in self.segments)
                and self.end_attached() == "B")

    def loop_segments(self) -> list[Segment]:
        """The rows a run of many cycles loops over: the cycle (:meth:`all_segments`), then,
        for a gait that :attr:`alternates`, its mirror image (every ``A`` and ``B`` magnet
        action exchanged), each ending on its section row, the second looping back to the
        first. The first cycle's rows are :meth:`all_segments`' (its section row leads to
        the mirror image instead of row 0)."""
        rows = self.all_segments()
        if not self.alternates:
            return rows
        n = len(rows)

        def mirrored(k: int, seg: Segment) -> Segment:
            nxt = seg.next
            if nxt is not None and nxt >= 0 and k < n - 1:
                nxt += n                 # a jump within the cycle stays within its copy
            return replace(seg, magnets=MIRRORED_MAGNETS.get(seg.magnets, seg.magnets),
                           next=nxt)

        return [*rows[:-1], replace(rows[-1], next=n),
                *(mirrored(k, seg) for k, seg in enumerate(rows))]

    def cycle_end_rows(self) -> list[int]:
        """The section rows of :meth:`loop_segments` (each ends a cycle)."""
        n = len(self.all_segments())
        return [n - 1, 2 * n - 1] if self.alternates else [n - 1]

    def loop_magnet_rows(self) -> list[int]:
        """Rows of :meth:`loop_segments` whose exit enters a segment that acts on the
        magnets: where the magnet actions of a run of many cycles are logged."""
        return _rows_before_magnets(self.loop_segments())

    @property
    def clocked(self) -> bool:
        """The clock runs on with ``period`` (the section is clock phase zero)."""
        return not math.isnan(self.period)

    @property
    def section_size(self) -> int:
        """Entries of the section state: 4 with a running clock, else 3."""
        return 4 if self.clocked else 3

    def all_segments(self) -> list[Segment]:
        """The segments with the section segment appended (the cycle's last row)."""
        if self.clocked:
            section = Segment("time", value=self.period, torque=self.section_torque,
                              ticked=self.section_ticked, clock="advance", cycle_end=True,
                              next=0, fail_status=L.ST_HORIZON)
        else:
            section = Segment("coord", coord="theta1", value=self.section_theta1,
                              direction=self.section_direction, torque=self.section_torque,
                              ticked=self.section_ticked, clock="reset", cycle_end=True,
                              next=0, fail_status=L.ST_NO_RETURN)
        return [*self.segments, section]

    def section_observer(self, row: int | None = None) -> Observer:
        """An exact observer of link 1 crossing ``section_theta1`` in ``section_direction``,
        watched in the section row (or in row ``row`` of :meth:`loop_segments`): where a
        cycle is measured when its section acts on a tick (its log row is the crossing
        itself, not the tick after it) or is a clock's phase (:attr:`records` ``'swap'``)."""
        return Observer("coord", "theta1", self.section_theta1, self.section_direction,
                        segment=len(self.segments) if row is None else int(row))

    def section_observers(self) -> tuple[Observer, ...]:
        """:meth:`section_observer` of each section row of :meth:`loop_segments`: the
        observers of a run of many cycles."""
        return tuple(self.section_observer(r) for r in self.cycle_end_rows())

    def loop_controller(self, observers=()) -> PhaseSequence:
        """The controller of a run of many cycles: :meth:`loop_segments` with ``observers``
        (e.g. :meth:`section_observers`)."""
        return PhaseSequence(self.loop_segments(), tuple(observers), self.tick,
                             self.tick_phase, self.rise)

    def attached_ends(self) -> list[frozenset]:
        """Ends attached during each row of the cycle (``{'A'}``, ``{'B'}``, both, none),
        from the magnet actions alone: the program is a fixed sequence."""
        ends, out = frozenset("A"), []
        for seg in self.all_segments():
            ends = _attached_after(seg.magnets, ends)
            out.append(ends)
        return out

    def frame_ends(self) -> list[str]:
        """The end (``'A'`` or ``'B'``) whose frame each row of the cycle
        (:meth:`all_segments`) runs in, from the magnet actions alone: the end the robot
        hangs from after the row's entry actions, or in flight (or pinned at both ends) the
        last end it hung from. The kernel states the state, and the motor torque on
        ``theta2``, in that frame (docs/model.md section 3)."""
        frame, out = "A", []
        for ends in self.attached_ends():
            if len(ends) == 1:
                frame = next(iter(ends))
            out.append(frame)
        return out

    def end_attached(self) -> str:
        """The end (``'A'`` or ``'B'``) the robot hangs from when it reaches the section."""
        ends = self.attached_ends()[-1]
        if len(ends) != 1:
            what = "no magnet" if not ends else "both magnets"
            raise ValueError(f"the cycle reaches its section with {what} on: the section "
                             "needs the robot hanging from one end")
        return next(iter(ends))

    def controller(self) -> PhaseSequence:
        return PhaseSequence(self.all_segments(), (), self.tick, self.tick_phase, self.rise)

    def program(self):
        return self.controller().program()


#: the frames a sequence gait's torques may be written in: ``attached_end`` (the kernel's:
#: each torque acts on theta2 of the frame of the end attached at the time) or ``motor`` (the
#: physical motor torque, its sign fixed to the links for the whole cycle)
TORQUE_FRAMES = ("attached_end", "motor")


def motor_frame_signs(gait: SequenceGait) -> np.ndarray:
    """Per row of the cycle (:meth:`SequenceGait.all_segments`), the factor (+1 or -1) that
    turns a torque in the motor frame into the kernel's, and back.

    The kernel applies a row's torque on ``theta2`` of the frame it runs in
    (:meth:`SequenceGait.frame_ends`); a flip to the other end's frame negates ``theta2``
    (docs/model.md section 3), so the same physical motor torque is ``+tau`` in rows that run
    in the frame of the end the cycle starts from (A) and ``-tau`` in rows that run in the
    other end's frame (after a swap within the cycle).
    """
    return np.array([1.0 if end == "A" else -1.0 for end in gait.frame_ends()])


def torques_from_motor_frame(gait: SequenceGait) -> SequenceGait:
    """The gait whose segment and section torques [N m] were written in the motor frame, with
    each converted to the kernel's frame (:func:`motor_frame_signs`): a row that runs in the
    frame of the other end than the cycle's start end gets the negated torque. Applied twice
    it returns the gait (a zero torque stays +0.0)."""
    signs = motor_frame_signs(gait)

    def kernel(torque: float, sign: float) -> float:
        return torque if sign > 0.0 or torque == 0.0 else -torque

    segs = tuple(replace(seg, torque=kernel(seg.torque, sign))
                 for seg, sign in zip(gait.segments, signs))
    return replace(gait, segments=segs, section_torque=kernel(gait.section_torque, signs[-1]))


def motorless(gait: SequenceGait) -> SequenceGait:
    """The gait with the motor off in every segment: a recorded schedule whose motor phase
    lasts no time (a collisionless swap, ``t_motor = 0``) replays without one, so no motor
    pulse is perturbed or reported where none acts."""
    return replace(gait, segments=tuple(replace(seg, torque=0.0) for seg in gait.segments),
                   section_torque=0.0)


def open_loop_gait(gait: SequenceGait, segment_times) -> SequenceGait:
    """The gait with every segment before the section ending at a fixed time.

    ``segment_times`` [s]: the exit times on the controller clock (which restarts at each
    section crossing), e.g. :func:`~monkeystudy.analysis.replay.cycle_times` of the fixed
    point (the section's own entry, if given, is ignored). Entry actions are kept; each guard becomes a ticked ``time`` guard,
    so a controller tick rounds the times up to its grid, as the 2009 study's 1 ms loop did.
    A gait with ``open_loop_section_ticked`` senses its section on the tick too (the 2009
    controller restarted its clock at the tick after the vertical).
    """
    times = np.asarray(segment_times, float).ravel()
    n = len(gait.segments)
    if times.size < n or not np.all(np.isfinite(times[:n])):
        raise ValueError(f"need {n} finite segment exit times, got {times[:n]}")
    if np.any(np.diff(np.concatenate([[0.0], times[:n]])) < 0.0):
        raise ValueError(f"segment exit times must not decrease: {times[:n]}")
    for k, s in enumerate(gait.segments):
        if s.clock != "keep":
            raise ValueError(f"segment {k} moves the controller clock (clock={s.clock!r}): "
                             "recorded times would be on a different clock")
    segs = tuple(replace(s, until="time", value=float(t), ticked=True, direction="rising")
                 for s, t in zip(gait.segments, times[:n]))
    # no segment swings freely to a guard any more: no start is provably unreachable
    return replace(gait, segments=segs, unreachable_below_floor=False,
                   section_ticked=gait.section_ticked or gait.open_loop_section_ticked)


#: where a :class:`SequenceGait`'s multi-cycle runs record each cycle
RECORDS = ("section", "swap")


def horizontal_gait(torque: float, tick: float = 0.0, *, tick_phase: float = 0.0,
                    period: float = math.nan) -> SequenceGait:
    """The study's horizontal gait (docs/model.md section 4) as a :class:`SequenceGait`.

    The search controller's first two rows (:class:`HorizontalSearch`: swing until the free
    end rises to the attached end's height, then swap with motor torque ``torque`` [N m]
    until the start's energy is restored), closed by the vertical (``theta1 = 0``, either
    direction, motor off), ``theta2 = 0`` at the start. One cycle runs exactly as
    :class:`HorizontalSearch` does; the gait carries the 2009 study's definitions:

    * its error does not wrap ``theta2`` (``wrap_theta2=False``);
    * a start below the swap energy floor is unreachable (``unreachable_below_floor``);
    * replayed open loop (:class:`OpenLoop`'s program), its clock restarts on the tick
      after the vertical (``open_loop_section_ticked``);
    * a multi-cycle run records each cycle from its swap (``records='swap'``).

    ``tick``, ``tick_phase`` [s]: the controller tick; ``period`` [s]: a clock that runs on
    (the open-loop replay's ``clock: run_on``), NaN for a clock restarting at the vertical.
    """
    return SequenceGait(HorizontalSearch(torque).segments()[:2], section_theta1=0.0,
                        section_direction="either", section_torque=0.0, theta2=0.0,
                        tick=tick, tick_phase=tick_phase, period=period, wrap_theta2=False,
                        unreachable_below_floor=True, open_loop_section_ticked=True,
                        records="swap")


@dataclass(frozen=True)
class Integrator:
    """Integrator settings with scipy ``solve_ivp`` semantics for ``rtol``/``atol``.

    ``max_time`` [s] is the horizon of one controller segment (a phase that has not ended by
    then fails with that segment's status).

    ``controller`` is the step-size controller: ``"scipy"`` (default) is scipy's, factor
    ``0.9 err^(-1/k)``, so the accepted steps equal ``solve_ivp``'s one for one; ``"pi"`` is
    Gustafsson's PI controller, ``0.9 err^(-0.7/k) err_prev^(0.4/k)`` (Hairer & Wanner II,
    sec. IV.2), which damps the grow-and-reject cycle of the high-order pairs (k is the error
    estimator's order + 1).
    """

    method: str = "dop853"
    rtol: float = 1e-10
    atol: float = 1e-12
    max_time: float = 3.0
    max_step: float = math.inf
    max_steps: int = 10_000_000
    controller: str = "scipy"

    def __post_init__(self):
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {sorted(METHODS)}, got {self.method!r}")
        if self.controller not in CONTROLLERS:
            raise ValueError(f"controller must be one of {sorted(CONTROLLERS)}, "
                             f"got {self.controller!r}")
        for name in ("rtol", "atol", "max_time", "max_step"):
            v = float(getattr(self, name))
            if math.isnan(v) or v <= 0:
                raise ValueError(f"{name} must be > 0, got {v!r}")
        if not math.isfinite(self.rtol) or not math.isfinite(self.atol):
            raise ValueError("rtol and atol must be finite")
        if self.rtol < 100 * np.finfo(float).eps:
            raise ValueError(f"rtol must be >= 100 eps ({100 * np.finfo(float).eps:.3g}), "
                             f"got {self.rtol!r}")


#: Step-size controllers: name -> kernel id (layout ``CONTROLLER_*``).
CONTROLLERS = {"scipy": L.CONTROLLER_SCIPY, "pi": L.CONTROLLER_PI}

#: Registered integrators: name -> (kernel id, order, description).
METHODS = {
    "rk45": (L.METHOD_RK45, 5, "Dormand-Prince 5(4), 4th-order free interpolant"),
    "dop853": (L.METHOD_DOP853, 8, "Dormand-Prince 8(5,3), 7th-order dense output"),
    "vern9": (L.METHOD_VERN9, 9, "Verner 9(8) (2010, 16 stages), 9th-order interpolant "
              "(nine extra stages, only on steps with an event)"),
}


def program_may_fly(prog: np.ndarray, start_phase: float) -> bool:
    """Whether a controller program run from a state of phase ``start_phase`` can enter
    flight: only a start in flight or a segment that turns a magnet off on entry without the
    swap can (``kernel/hybrid.apply_magnets``)."""
    if int(start_phase) == L.PHASE_FLIGHT:
        return True
    rows = np.asarray(prog, dtype=float).reshape(-1, L.N_SEG_COLS)
    release = (rows[:, L.S_SWAP] <= 0) & ((rows[:, L.S_MAG_A] == 0) | (rows[:, L.S_MAG_B] == 0))
    return bool(release.any())


def kernel_method(settings: np.ndarray, prog: np.ndarray | None = None,
                  start_phase: float | None = None):
    """The integrator of a settings vector as the first argument of every kernel that
    integrates (:func:`~monkeystudy.kernel.integrate.method_scalar`: a scalar whose type
    names the method, so each method compiles only its own steps). Given the program and the
    phase it starts in, a run that cannot fly (:func:`program_may_fly`) compiles the swing
    steps only."""
    flies = True if prog is None or start_phase is None else program_may_fly(prog,
                                                                              start_phase)
    return method_scalar(settings[L.C_METHOD], flies)


#: the kernel's relative zero band of a guard at a segment's start (``C_ZERO_BAND``): a guard
#: within ``ZERO_BAND * (1 + |value|)`` of its zero there is taken as on it, and does not fire
ZERO_BAND = 1e-12


def settings_vector(integrator: Integrator, *, tick: float = 0.0, tick_phase: float = 0.0,
                    t_end: float = math.inf, max_cycles: int = 0, sample_dt: float = 0.0,
                    max_drop: float = math.inf, zero_band: float = ZERO_BAND) -> np.ndarray:
    """The kernel's settings vector (layout ``C_*``)."""
    s = np.zeros(L.N_SETTINGS)
    s[L.C_METHOD] = METHODS[integrator.method][0]
    s[L.C_RTOL] = integrator.rtol
    s[L.C_ATOL] = integrator.atol
    s[L.C_MAX_SEGMENT_TIME] = integrator.max_time
    s[L.C_T_END] = t_end
    s[L.C_MAX_CYCLES] = max_cycles
    s[L.C_TICK] = tick
    s[L.C_TICK_PHASE] = tick_phase
    s[L.C_SAMPLE_DT] = sample_dt
    s[L.C_MAX_STEPS] = integrator.max_steps
    s[L.C_MAX_STEP] = integrator.max_step
    s[L.C_MAX_DROP] = max_drop
    s[L.C_ZERO_BAND] = zero_band
    s[L.C_CONTROLLER] = CONTROLLERS[integrator.controller]
    return s
