"""Open-loop gait design: the spectral radius of the return map over schedule and robot.

A *design* is an open-loop schedule and a robot. The schedule runs on a clock that restarts
each time link 1 passes the vertical: the magnets swap at ``t_switch`` [s], a motor pulse of
``torque`` [N m] starts ``motor_start`` [s] after the swap and lasts ``t_motor`` [s], and an
optional second pulse (``pulse2_start`` after the swap, ``pulse2_duration``,
``pulse2_torque``) follows. The robot is the base robot reshaped by ``com``, ``inertia``,
``mass_ratio`` and ``length_ratio`` (:data:`PARAMETERS` gives units, meanings and the
bounds of what can be built).

For each design, :func:`evaluate_design` solves the gait as a fixed point of the return map
on ``theta1 = 0`` (Newton in compiled code, :func:`monkeystudy.kernel.design.fixed_point`),
optionally together with one schedule value (``balance``) chosen so the gait returns to its
height each cycle (an open-loop schedule fixes no height), and returns the multipliers by
finite differences and, on request, by variational equations with saltation matrices.
Stability is the spectral radius ``rho`` per step: ``max |lambda|`` of the cycle's map, to
the power ``1 / steps`` when a cycle takes two steps (links that are not mirror images make
the frame's flip at each swap compare unlike links, so a cycle is two steps then).

With ``clock="run_on"`` the schedule's clock never looks at the state: it runs on with the
gait's period, and nothing is sensed at all. Every such gait is a gait of the restarting
clock (the same orbit, its vertical crossing at clock phase zero), so the gait is solved as
above; its stability is that of the stroboscopic map, the state ``(theta1, theta2, dtheta1,
dtheta2)`` at clock phase zero, one period later (four multipliers: a running clock keeps no
phase reference, so errors in the timing of the orbit count too).
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Callable, ClassVar, Mapping

import numpy as np

from ..controllers import (
    Integrator, Segment, SequenceGait, kernel_method, motor_frame_signs, settings_vector,
)
from ..kernel import layout as L
from ..kernel.design import (
    DESIGN_STATUS_NAMES, DS_NO_CYCLE, DS_OK, DS_STENCIL, I_ADVANCE, I_DEFECT, I_ERROR,
    I_ITERATIONS, I_LOSS, I_NFEV, I_PERIOD, I_RISE, N_INFO, clocked_jacobian, fixed_point,
)
from ..robot import Link, Robot
from ..simulation import Status, energies, run_controller
from .multipliers import jacobian_fd, sorted_eigs
from .replay import cycles_to_bound, growth_per_cycle, sequence_basin, sequence_cycles
from .survival import Noise, SurvivalRuns, survival_runs
from .sections import (
    TIGHT, bar_catch_rows, check_cycle_frame, cycle_catches, cycle_full_map, cycle_section_state,
)
from .variational import sequence_variational_jacobian


@dataclass(frozen=True)
class Parameter:
    """A design parameter: unit, buildable bounds, what it is, and whether it shapes the
    schedule or the robot."""

    unit: str
    lower: float
    upper: float
    meaning: str
    part: str   # "schedule" | "robot"


#: Every design parameter, with the bounds of what can be built and run. Schedule times are
#: on the controller clock, which restarts when link 1 passes the vertical; pulse starts count
#: from the swap (negative: before it). Torques act on theta2 of the frame of the end
#: attached at the time. Robot values describe link 1 of a robot of the base's total mass and
#: length; link 2 mirrors it (CG at the same distance from the joint).
PARAMETERS: dict[str, Parameter] = {
    "t_switch": Parameter("s", 0.05, 1.5, "magnet swap, after the vertical", "schedule"),
    "motor_start": Parameter("s", -0.5, 0.5, "motor pulse start, after the swap", "schedule"),
    "t_motor": Parameter("s", 0.0, 0.5, "motor pulse duration", "schedule"),
    "torque": Parameter("N m", -2.0, 2.0, "motor pulse torque (the 2009 motor gives 0.6354)",
                        "schedule"),
    "pulse2_start": Parameter("s", -0.5, 1.0, "second pulse start, after the swap",
                              "schedule"),
    "pulse2_duration": Parameter("s", 0.0, 0.5, "second pulse duration", "schedule"),
    "pulse2_torque": Parameter("N m", -2.0, 2.0, "second pulse torque", "schedule"),
    "com": Parameter("m", 0.05, 0.60, "link 1's CG from end A (link 2's from the joint "
                     "mirrors it), at the base link length", "robot"),
    "inertia": Parameter("kg m2", 0.001, 0.05, "inertia of a link about its CG, at the base "
                         "mass and length; at most m c (L - c) (all mass at the two ends)",
                         "robot"),
    "mass_ratio": Parameter("1", 0.5, 2.0, "link 2 mass over link 1 mass, total mass fixed",
                            "robot"),
    "length_ratio": Parameter("1", 0.67, 1.5, "link 2 length over link 1 length, total "
                              "length fixed", "robot"),
}

#: schedule values solved so that the gait returns to its height (or none)
BALANCES = ("t_switch", "torque", "t_motor", "none")
#: the schedule's clock: restarted at each vertical crossing, or running on with the period
CLOCKS = ("reset_at_vertical", "run_on")
#: what a design search minimises
OBJECTIVES = ("spectral_radius", "spectral_radius_energy")
#: status of a design whose gait converged (the others: :data:`STATUS_NAMES`)
DESIGN_OK = DS_OK
#: status of a design that breaks a bound (not simulated)
OUT_OF_BOUNDS = len(DESIGN_STATUS_NAMES)
STATUS_NAMES = (*DESIGN_STATUS_NAMES, "out_of_bounds")


def check_values(values: Mapping[str, float]) -> str:
    """Why a set of design values cannot be built ('' if it can)."""
    for name, v in values.items():
        p = PARAMETERS[name]
        if not (p.lower <= v <= p.upper):
            return f"{name} = {v!r} {p.unit} outside [{p.lower}, {p.upper}]"
    return ""


@dataclass(frozen=True)
class DesignSpace:
    """The base of a design search: the robot (mirror-image links), the base value of every
    parameter, the balance, and the solver's settings.

    Parameters
    ----------
    robot : Robot
        The base robot; ``com``, ``inertia``, ``mass_ratio`` and ``length_ratio`` reshape it.
    base : mapping
        Values of the parameters that are not searched (missing: :meth:`defaults`).
    balance : {"t_switch", "torque", "t_motor", "none"}
        The schedule value solved so the gait returns to its height (its value in a design
        is the Newton start). The swap time sets where the free end attaches, so
        ``t_switch`` is the natural choice: the motor program barely moves the height.
    two_step : bool
        A cycle is two steps (needed when the links may differ: ``mass_ratio`` or
        ``length_ratio`` free or not 1).
    integrator : Integrator
        The return map's integrator (tight: the finite differences divide its error by
        ``fd_step``).
    tol : float
        Newton's tolerance on ``|P(z) - z|`` (and the height) [rad, rad s-1, m].
    max_iter : int
        Newton iterations (from a start near the gait it converges in 4-8; more are spent
        on starts that lead nowhere).
    fd_step : float
        Relative finite-difference step.
    clock : {"reset_at_vertical", "run_on"}
        The schedule's clock: restarted when link 1 passes the vertical, or running on with
        the gait's period (stability of the stroboscopic map; one-step cycles only).
    """

    robot: Robot
    base: Mapping[str, float] = field(default_factory=dict)
    balance: str = "t_switch"
    two_step: bool = False
    integrator: Integrator = TIGHT
    tol: float = 1e-11
    max_iter: int = 12
    fd_step: float = 1e-5
    clock: str = "reset_at_vertical"

    #: the return map's state leaves the height out (neutral for every schedule of this
    #: space: its guards sense time and the vertical crossing only)
    height_in_map: ClassVar[bool] = False
    #: the section: link 1 at the vertical
    section_theta1: ClassVar[float] = 0.0
    #: what a run of a design's gait for many cycles is called (its schedule runs on time)
    replay_name: ClassVar[str] = "open-loop replay"

    def __post_init__(self):
        if self.balance not in BALANCES:
            raise ValueError(f"balance must be one of {BALANCES}, got {self.balance!r}")
        if self.clock not in CLOCKS:
            raise ValueError(f"clock must be one of {CLOCKS}, got {self.clock!r}")
        if self.clock == "run_on" and self.two_step:
            raise ValueError("a running clock's cycle is one step: the links must be mirror "
                             "images (mass_ratio and length_ratio 1)")
        unknown = set(self.base) - set(PARAMETERS)
        if unknown:
            raise ValueError(f"unknown design parameters {sorted(unknown)}; known: "
                             f"{sorted(PARAMETERS)}")
        if not self.robot.is_mirror_image:
            raise ValueError("the base robot of a design search needs mirror-image links")

    @property
    def steps(self) -> int:
        """Steps per cycle of the return map."""
        return 2 if self.two_step else 1

    @property
    def n_multipliers(self) -> int:
        """Size of the return map's state: 3 on the section, 4 with a running clock."""
        return 4 if self.clock == "run_on" else 3

    def parameter(self, name: str) -> Parameter:
        """A design parameter's unit, bounds and meaning."""
        return PARAMETERS[name]

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Every parameter a design of this space has a value of."""
        return tuple(PARAMETERS)

    def defaults(self) -> dict[str, float]:
        """The base robot's values of the robot parameters, and a schedule without pulses
        (``t_switch`` must be given)."""
        link = self.robot.link1
        return {"motor_start": 0.0, "t_motor": 0.0, "torque": 0.0, "pulse2_start": 0.0,
                "pulse2_duration": 0.0, "pulse2_torque": 0.0, "com": link.com,
                "inertia": link.inertia, "mass_ratio": 1.0, "length_ratio": 1.0}

    def values(self, free: Mapping[str, float] | None = None) -> dict[str, float]:
        """Every parameter's value: the defaults, the base, then ``free``."""
        out = self.defaults()
        out.update({k: float(v) for k, v in self.base.items()})
        out.update({k: float(v) for k, v in (free or {}).items()})
        if "t_switch" not in out:
            raise ValueError("a design needs t_switch (in the base or the free parameters)")
        return out

    # --- the robot ----------------------------------------------------------------------
    def robot_for(self, values: Mapping[str, float]) -> Robot:
        """The robot of a design: total mass and length of the base, link 1's CG at
        ``com`` (scaled with its length), inertia ``inertia`` (scaled with mass and length
        squared), link 2 the mirror image of link 1 reshaped by the two ratios."""
        b = self.robot.link1
        mass, length = 2.0 * b.mass, 2.0 * b.length
        mu, lam = values["mass_ratio"], values["length_ratio"]
        m1, l1 = mass / (1.0 + mu), length / (1.0 + lam)
        m2, l2 = mass - m1, length - l1
        frac = values["com"] / b.length                 # CG from A, in link lengths
        gyr2 = values["inertia"] / (b.mass * b.length ** 2)
        return replace(self.robot, name="design",
                       link1=Link(m1, l1, frac * l1, m1 * gyr2 * l1 ** 2),
                       link2=Link(m2, l2, (1.0 - frac) * l2, m2 * gyr2 * l2 ** 2))

    def buildable(self, values: Mapping[str, float]) -> str:
        """Why a design cannot be built or run ('' if it can): a value out of bounds, an
        inertia no mass distribution on the link gives, or a pulse before the vertical."""
        why = check_values(values)
        if why:
            return why
        c, length = values["com"], self.robot.link1.length
        if values["inertia"] > self.robot.link1.mass * c * (length - c) * (1 + 1e-12):
            return (f"inertia {values['inertia']:.4g} kg m2 above m c (L - c) = "
                    f"{self.robot.link1.mass * c * (length - c):.4g}: no mass distribution "
                    "on the link has it")
        for name in ("motor_start", "pulse2_start"):
            if values["t_switch"] + values[name] < 0.0:
                return f"{name} puts a pulse before the vertical (t_switch + {name} < 0)"
        return ""

    # --- the schedule -------------------------------------------------------------------
    def step_rows(self, values: Mapping[str, float]) -> tuple[list[Segment], list[str], float]:
        """The rows of one step before its closing vertical crossing, the schedule event
        each row's guard is (``swap``, ``pulse1_on``, ``pulse1_off``, ``pulse2_on``,
        ``pulse2_off``; ``actions``: a zero-length row that applies the last event's
        actions), and the torque left on until the vertical [N m]."""
        ts = values["t_switch"]
        on1 = ts + values["motor_start"]
        on2 = ts + values["pulse2_start"]
        events = [(ts, "swap"), (on1, "pulse1_on"), (on1 + values["t_motor"], "pulse1_off"),
                  (on2, "pulse2_on"), (on2 + values["pulse2_duration"], "pulse2_off")]
        order = sorted(range(len(events)), key=lambda k: (events[k][0], k))
        torque = {"pulse1": values["torque"], "pulse2": values["pulse2_torque"]}
        active: set[str] = set()
        rows, kinds = [], []
        magnets, tau = "keep", 0.0
        for k in order:
            t, what = events[k]
            rows.append(Segment("time", value=t, magnets=magnets, torque=tau,
                                fail_status=L.ST_NO_SWITCH if not rows else L.ST_HORIZON))
            kinds.append(what)
            magnets = "swap" if what == "swap" else "keep"
            if what.endswith("_on"):
                active.add(what[:-3])
            elif what.endswith("_off"):
                active.discard(what[:-4])
            tau = sum(torque[p] for p in sorted(active))
        if magnets != "keep":
            # the swap is the last event: a row that ends as it starts applies it, so the
            # vertical row that follows carries no action of its own
            rows.append(Segment("time", value=events[order[-1]][0], magnets=magnets,
                                torque=tau))
            kinds.append("actions")
        return rows, kinds, tau

    def gait(self, values: Mapping[str, float]) -> SequenceGait:
        """The design's cycle as a sequence gait (one or two steps, section at the
        vertical, the clock restarting at each vertical crossing)."""
        rows, _, tau = self.step_rows(values)
        if self.two_step:
            vertical = Segment("coord", coord="theta1", value=0.0, direction="either",
                               torque=tau, ticked=False, clock="reset",
                               fail_status=L.ST_NO_RETURN)
            rows = [*rows, vertical, *rows]
        return SequenceGait(rows, section_theta1=0.0, section_direction="either",
                            section_torque=tau)

    def gait_for(self, values: Mapping[str, float]) -> SequenceGait:
        """The design's gait (:meth:`gait`; the name every design space shares)."""
        return self.gait(values)

    def cycle_gait(self, values: Mapping[str, float], period: float) -> SequenceGait:
        """The gait whose cycles the design's stability and replays are about: :meth:`gait`,
        or with a running clock the same rows closed at ``period`` [s] (the gait's) instead
        of at the vertical crossing."""
        gait = self.gait(values)
        return replace(gait, period=float(period)) if self.clock == "run_on" else gait

    def row_kinds(self, values: Mapping[str, float]) -> list[str]:
        """What each row of :meth:`gait`'s program is (``vertical``, ``section`` or a
        schedule event, see :meth:`step_rows`)."""
        _, kinds, _ = self.step_rows(values)
        rows = [*kinds, "vertical", *kinds] if self.two_step else kinds
        return [*rows, "section"]

    def programs(self, values: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """``(prog0, dprog)``: the design's program is ``prog0 + q * dprog`` for the balance
        value ``q`` (``dprog`` is zero without a balance). ``t_switch`` moves every event of
        the schedule, ``t_motor`` the end of pulse 1, ``torque`` the torque of the rows where
        pulse 1 is on; the row order of the design is kept (it holds near the design)."""
        prog, _ = self.gait(values).program()
        dprog = np.zeros_like(prog)
        if self.balance == "none":
            return prog, dprog
        kinds = self.row_kinds(values)
        if self.balance == "torque":
            unit = dict(values, torque=1.0, pulse2_torque=0.0)
            dprog[:, L.S_TORQUE] = self.gait(unit).program()[0][:, L.S_TORQUE]
        else:
            moves = ({"swap", "pulse1_on", "pulse1_off", "pulse2_on", "pulse2_off", "actions"}
                     if self.balance == "t_switch" else {"pulse1_off"})
            for r, what in enumerate(kinds):
                if what in moves:
                    dprog[r, L.S_GVALUE] = 1.0
        q = values[self.balance]
        base = prog - q * dprog
        # equal to round-off (the sums are grouped differently): ~1e-16 s or N m
        if not np.allclose(base + q * dprog, prog, rtol=1e-14, atol=1e-14):
            raise RuntimeError(f"the program is not affine in {self.balance} at this design")
        return base, dprog


#: names of a segment design's parameters: ``segment<k>_value``, ``segment<k>_torque`` (k
#: from 1, the gait's segments in the order the study lists them)
SEGMENT_PARAMETER = re.compile(r"segment([1-9][0-9]*)_(value|torque)")

#: units of a segment's guard value, by guard (``coord`` guards: by coordinate)
GUARD_VALUE_UNITS = {"time": "s", "free_end_height": "m", "energy_restored": "J",
                     "energy": "J", "free_end_y": "m"}
COORD_UNITS = {"x": "m", "y": "m", "theta1": "rad", "theta2": "rad", "dx": "m s-1",
               "dy": "m s-1", "dtheta1": "rad s-1", "dtheta2": "rad s-1"}
#: bounds of a segment design's values: a torque the motor model accepts [N m], a time on the
#: controller clock [s] and any other guard value (in its units)
SEGMENT_TORQUE_BOUND = 2.0
SEGMENT_TIME_BOUND = 3.0
SEGMENT_VALUE_BOUND = 100.0


@dataclass(frozen=True)
class SegmentDesignSpace:
    """The base of a design search over a sequence gait's segments: the values of their
    guards and their torques, the rest of the gait as it is.

    A design's gait is solved as a fixed point of the return map on the gait's section
    (Newton on the section state, no balance: a gait that holds its height does so by a
    guard on a world height, e.g. a catch at ``free_end_y``), and its stability is measured
    on the full map, the attached end's height included (``height_in_map``: four
    multipliers; :func:`~monkeystudy.analysis.cycle_full_map`), or on the section map.

    Parameters
    ----------
    base_gait : SequenceGait
        The base gait, torques in the kernel's frame (as
        :meth:`~monkeystudy.study.models.SequenceGaitSpec.gait` builds it); its section
        restarts the clock.
    robot : Robot
        The robot (mirror-image links: each cycle is measured in the frame of the end it
        ends on).
    base : mapping
        Values of the parameters that are not searched (missing: the gait's own).
    motor_frame : bool
        Torque parameters are the physical motor torque (the sign fixed to the links for the
        cycle, :func:`~monkeystudy.controllers.motor_frame_signs`), else the kernel's.
    height_in_map : bool
        Stability of the full map (height included) instead of the section map.
    integrator, tol, max_iter, fd_step
        As :class:`DesignSpace`'s.
    torque_limit : float, optional
        The largest torque magnitude a torque parameter may take [N m]: default the robot's
        motor's (:class:`~monkeystudy.Motor`), or :data:`SEGMENT_TORQUE_BOUND` for a motor
        that states no limit.
    min_offset_margin : float
        A gait that catches bars: the least offset margin a catch may have [m] (its bar's
        window less the free end's horizontal distance from the bar at the catch); a design
        whose gait catches with less is rejected (status ``out_of_bounds``). 0: every catch
        inside its window.
    """

    base_gait: SequenceGait
    robot: Robot
    base: Mapping[str, float] = field(default_factory=dict)
    motor_frame: bool = False
    height_in_map: bool = True
    integrator: Integrator = TIGHT
    tol: float = 1e-11
    max_iter: int = 12
    fd_step: float = 1e-5
    torque_limit: float | None = None
    min_offset_margin: float = 0.0

    balance: ClassVar[str] = "none"
    clock: ClassVar[str] = "reset_at_vertical"
    two_step: ClassVar[bool] = False
    steps: ClassVar[int] = 1
    #: a run of the design's gait for many cycles: by its own controller, guards and all
    replay_name: ClassVar[str] = "replay"

    def __post_init__(self):
        if self.base_gait.clocked:
            raise ValueError("a segment design needs a gait whose clock restarts at its "
                             "section (no period)")
        # a cycle that ends hanging from A (two swaps) is defined for any robot
        check_cycle_frame(self.base_gait, self.robot)
        if not (self.torque_bound > 0 and math.isfinite(self.torque_bound)):
            raise ValueError(f"torque_limit must be positive and finite, got "
                             f"{self.torque_limit!r} N m")
        for name in self.base:
            self.parameter(name)
        if not (self.min_offset_margin >= 0.0 and math.isfinite(self.min_offset_margin)):
            raise ValueError(f"min_offset_margin must be finite and >= 0, got "
                             f"{self.min_offset_margin!r} m")

    @property
    def catch_rows(self) -> list[int]:
        """Rows of the gait's segments (from 0) that catch a bar
        (:func:`~monkeystudy.analysis.sections.bar_catch_rows`)."""
        return bar_catch_rows(self.base_gait)

    @property
    def torque_bound(self) -> float:
        """The largest torque magnitude of a torque parameter [N m]: ``torque_limit`` if
        given, else the robot's motor's, else :data:`SEGMENT_TORQUE_BOUND`."""
        if self.torque_limit is not None:
            return float(self.torque_limit)
        motor = self.robot.motor.torque_limit
        return motor if math.isfinite(motor) else SEGMENT_TORQUE_BOUND

    @property
    def section_theta1(self) -> float:
        """Link 1's angle on the section [rad]."""
        return float(self.base_gait.section_theta1)

    @property
    def n_multipliers(self) -> int:
        """Size of the map's state: 4 with the height, else 3."""
        return 4 if self.height_in_map else 3

    def _signs(self) -> np.ndarray:
        return (motor_frame_signs(self.base_gait)[:len(self.base_gait.segments)] if self.motor_frame
                else np.ones(len(self.base_gait.segments)))

    def parameter(self, name: str) -> Parameter:
        """The unit, bounds and meaning of ``segment<k>_value`` or ``segment<k>_torque``
        (``ValueError`` for another name or a segment the gait does not have)."""
        m = SEGMENT_PARAMETER.fullmatch(name)
        n = len(self.base_gait.segments)
        if m is None or not 1 <= int(m.group(1)) <= n:
            raise ValueError(f"unknown design parameter {name!r}: a segment design's are "
                             f"segment<k>_value and segment<k>_torque, k from 1 to {n}")
        k = int(m.group(1))
        seg = self.base_gait.segments[k - 1]
        if m.group(2) == "torque":
            frame = "motor" if self.motor_frame else "attached end's"
            return Parameter("N m", -self.torque_bound, self.torque_bound,
                             f"segment {k}'s motor torque ({frame} frame)", "schedule")
        if seg.until == "bar":
            raise ValueError(f"{name}: segment {k} catches a bar, and its value is the bar's "
                             f"rise (the ladder's geometry, data), not a design parameter")
        if seg.until == "coord":
            unit, what = COORD_UNITS[seg.coord], f"{seg.coord} {seg.direction}"
        else:
            unit, what = GUARD_VALUE_UNITS.get(seg.until, "1"), seg.until
        if seg.until == "time":
            return Parameter(unit, 0.0, SEGMENT_TIME_BOUND,
                             f"segment {k} ends at this time on the controller clock",
                             "schedule")
        return Parameter(unit, -SEGMENT_VALUE_BOUND, SEGMENT_VALUE_BOUND,
                         f"segment {k} ends when {what} crosses this value", "schedule")

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(f"segment{k}_{what}" for k in range(1, len(self.base_gait.segments) + 1)
                     for what in ("value", "torque"))

    def values(self, free: Mapping[str, float] | None = None) -> dict[str, float]:
        """Every parameter's value: the gait's, then the base, then ``free``."""
        out = {}
        for k, (seg, sign) in enumerate(zip(self.base_gait.segments, self._signs()), start=1):
            out[f"segment{k}_value"] = float(seg.value)
            out[f"segment{k}_torque"] = float(sign * seg.torque) if seg.torque else 0.0
        out.update({k: float(v) for k, v in self.base.items()})
        out.update({k: float(v) for k, v in (free or {}).items()})
        return out

    def robot_for(self, values: Mapping[str, float]) -> Robot:
        """The robot (a segment design does not reshape it)."""
        return self.robot

    def buildable(self, values: Mapping[str, float]) -> str:
        """Why a design cannot run ('' if it can): a value outside its bounds, or a bar's
        rise (a catching segment's value: the ladder's, no parameter) other than the gait's."""
        for k, seg in enumerate(self.base_gait.segments, start=1):
            if seg.until == "bar" and values[f"segment{k}_value"] != seg.value:
                return (f"segment{k}_value = {values[f'segment{k}_value']!r} m: segment {k} "
                        f"catches a bar {seg.value!r} m above, the ladder's geometry")
        for name in self.parameter_names:
            if name.endswith("_value") and self.base_gait.segments[
                    int(SEGMENT_PARAMETER.fullmatch(name).group(1)) - 1].until == "bar":
                continue
            p = self.parameter(name)
            v = values[name]
            if not p.lower <= v <= p.upper:
                return f"{name} = {v!r} {p.unit} outside [{p.lower}, {p.upper}]"
        return ""

    def gait_for(self, values: Mapping[str, float]) -> SequenceGait:
        """The design's gait: the base gait with its segments' values and torques (in the
        kernel's frame)."""
        segs = tuple(replace(seg, value=values[f"segment{k}_value"],
                             torque=sign * values[f"segment{k}_torque"] + 0.0)
                     for k, (seg, sign) in enumerate(zip(self.base_gait.segments, self._signs()),
                                                     start=1))
        return replace(self.base_gait, segments=segs)

    def cycle_gait(self, values: Mapping[str, float], period: float) -> SequenceGait:
        """The gait whose cycles the design's stability and replays are about."""
        return self.gait_for(values)

    def programs(self, values: Mapping[str, float]) -> tuple[np.ndarray, np.ndarray]:
        """``(prog, 0)``: the design's program (no balance)."""
        prog, _ = self.gait_for(values).program()
        return prog, np.zeros_like(prog)


@dataclass
class DesignResult:
    """One design's gait and its stability (see :func:`evaluate_design`)."""

    values: dict[str, float]
    status: int                      # DS_* or OUT_OF_BOUNDS
    z: np.ndarray                    # fixed point (theta2 [rad], dtheta1, dtheta2 [rad s-1])
    jacobian_fd: np.ndarray          # dP/dz by finite differences
    multipliers_fd: np.ndarray       # eigenvalues, decreasing modulus
    spectral_radius_fd: float        # per step
    jacobian: np.ndarray             # dP/dz by variational equations (NaN: not computed)
    multipliers: np.ndarray
    spectral_radius: float           # per step, by variational equations (NaN: not computed)
    error: float                     # squared section error |P(z) - z|^2
    rise: float                      # height change per cycle [m]
    advance: float                   # horizontal advance per cycle [m]
    energy_lost: float               # at the cycle's impacts [J]
    period: float                    # [s]
    iterations: int
    nfev: int
    message: str = ""
    clocked: bool = False            # a running clock: the map's state is (0, z)
    # a gait that catches bars: per catching segment, in order (NaN: no catch)
    catch_offset_margin: np.ndarray = field(default_factory=lambda: np.empty(0))  # [m]
    catch_speed: np.ndarray = field(default_factory=lambda: np.empty(0))          # [m s-1]

    @property
    def ok(self) -> bool:
        return self.status == DS_OK

    @property
    def state(self) -> np.ndarray:
        """The cycle's start on its map: ``z``, or with a running clock ``(theta1 = 0, z)``
        at clock phase zero."""
        return np.concatenate([[0.0], self.z]) if self.clocked else self.z.copy()

    @property
    def full_state(self) -> np.ndarray:
        """The full map's state at the fixed point: ``(y = 0 [m], theta2, dtheta1,
        dtheta2)`` (the cycle starts at the height of its section)."""
        return np.concatenate([[0.0], self.z])

    @property
    def energy_per_metre(self) -> float:
        """Energy the motor restores per metre travelled [J m-1] (= impact losses at a
        horizontal gait)."""
        return self.energy_lost / self.advance if self.advance > 0 else math.nan

    def objective(self, kind: str = "spectral_radius", energy_weight: float = 0.0,
                  catch_speed_weight: float = 0.0) -> float:
        """The search's objective: ``rho`` (finite differences), plus ``energy_weight`` [m
        J-1] times the energy per metre for ``spectral_radius_energy``, plus
        ``catch_speed_weight`` [s m-1] times the largest catch speed of a gait that catches
        bars (:func:`objective_value`); inf if the design has no gait."""
        if not self.ok or not math.isfinite(self.spectral_radius_fd):
            return math.inf
        return objective_value(kind, self.spectral_radius_fd, self.energy_per_metre,
                               energy_weight, self.max_catch_speed, catch_speed_weight)

    @property
    def max_catch_speed(self) -> float:
        """The largest speed of the hook just before a catch [m s-1] (NaN: no catch)."""
        return float(np.max(self.catch_speed)) if self.catch_speed.size else math.nan

    @property
    def min_offset_margin(self) -> float:
        """The least offset margin of the cycle's catches [m] (NaN: no catch)."""
        return (float(np.min(self.catch_offset_margin)) if self.catch_offset_margin.size
                else math.nan)


def objective_value(kind: str, rho, energy_per_metre, energy_weight: float, catch_speed,
                    catch_speed_weight: float):
    """A design search's objective from a design's spectral radius per step ``rho``, its
    energy per metre [J m-1] and its largest catch speed [m s-1] (scalars or arrays):
    ``rho``, plus ``energy_weight`` [m J-1] times the energy per metre for
    ``spectral_radius_energy``, plus ``catch_speed_weight`` [s m-1] times the catch speed
    when that weight is positive."""
    value = rho if kind == "spectral_radius" else rho + energy_weight * energy_per_metre
    if catch_speed_weight > 0.0:
        value = value + catch_speed_weight * catch_speed
    return value


def spectral_radius(J: np.ndarray, steps: int) -> float:
    """``max |eig J|`` per step (to the power ``1 / steps``)."""
    if not np.all(np.isfinite(J)):
        return math.nan
    return float(np.max(np.abs(np.linalg.eigvals(J)))) ** (1.0 / steps)


def motor_frame_pulses(values: Mapping[str, float]) -> list[tuple[float, float, float]]:
    """A design's pulses in the motor frame: ``(from [s], to [s], torque [N m])`` of the
    cycle's first step, times from the vertical crossing.

    A design states each pulse as the kernel applies it, on theta2 of the frame of the end
    attached at the time; theta2 changes sign at the swap (``t_switch``), so the part of a
    pulse after the swap is the opposite physical torque: it is returned as a pulse of its
    own, its torque negated (the motor frame is the frame of the end attached at the step's
    start). ``motor_start`` and ``pulse2_start`` count from the swap.
    """
    ts = values["t_switch"]
    kernel = [(ts + values["motor_start"], ts + values["motor_start"] + values["t_motor"],
               values["torque"])]
    if values.get("pulse2_duration", 0.0) > 0 and values.get("pulse2_torque", 0.0) != 0:
        on = ts + values["pulse2_start"]
        kernel.append((on, on + values["pulse2_duration"], values["pulse2_torque"]))
    out = []
    for a, b, tau in kernel:
        if b <= a or tau == 0:
            continue
        if a < ts:
            out.append((a, min(b, ts), tau))
        if b > ts:
            out.append((max(a, ts), b, -tau))
    return sorted(out)


def evaluate_design(space: DesignSpace, free: Mapping[str, float], z0,
                    *, variational: bool = False, diagnose: bool = True) -> DesignResult:
    """Solve a design's gait from the section-state guess ``z0`` and measure its stability.

    Parameters
    ----------
    space : DesignSpace
    free : mapping
        The searched parameters' values (the rest from ``space``).
    z0 : array_like, shape (3,)
        Newton's start ``(theta2 [rad], dtheta1, dtheta2 [rad s-1])``.
    variational : bool
        Also compute the Jacobian by variational equations (a few milliseconds more).
    diagnose : bool
        A gait that catches bars and has no gait here: say whether its catch falls outside
        a bar's window (:func:`missed_bar`).

    Returns
    -------
    DesignResult
        With ``values`` holding the solved balance value.
    """
    values = space.values(free)
    n = 3
    k = space.n_multipliers
    clocked = space.clock == "run_on"
    nank = np.full((k, k), np.nan)
    why = space.buildable(values)
    if why:
        return DesignResult(values, OUT_OF_BOUNDS, np.full(n, np.nan), nank,
                            np.full(k, np.nan), math.nan, nank.copy(), np.full(k, np.nan),
                            math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, 0, 0,
                            why, clocked)
    robot = space.robot_for(values)
    prog0, dprog = space.programs(values)
    balance = space.balance != "none"
    u0 = np.empty(n + 1 if balance else n)
    u0[:n] = np.asarray(z0, float)
    if balance:
        u0[n] = values[space.balance]
    settings = settings_vector(space.integrator)
    u = np.empty_like(u0)
    DP = np.empty((n, n))
    info = np.empty(N_INFO)
    status = fixed_point(kernel_method(settings, prog0, L.PHASE_SWING), robot.params(), prog0,
                         dprog, np.empty((0, L.N_OBS_COLS)), settings,
                         space.section_theta1, balance, u0, space.tol, space.max_iter,
                         space.fd_step, u, DP, info)
    if balance:
        values[space.balance] = float(u[n])
        why = check_values({space.balance: values[space.balance]})
        if why and status == DS_OK:
            status = OUT_OF_BOUNDS
    z = u[:n].copy()
    res = DesignResult(values, int(status), z, DP.copy(), sorted_eigs(DP) if status == DS_OK
                       else np.full(n, np.nan), spectral_radius(DP, space.steps), nank,
                       np.full(k, np.nan), math.nan, float(info[I_ERROR]),
                       float(info[I_RISE]), float(info[I_ADVANCE]), float(info[I_LOSS]),
                       float(info[I_PERIOD]), int(info[I_ITERATIONS]), int(info[I_NFEV]),
                       why if status == OUT_OF_BOUNDS else "", clocked)
    if status == DS_OK and clocked:
        clocked_stability(space, res, robot, settings)
    if status == DS_OK and space.height_in_map:
        full_map_stability(space, res)
    catching = isinstance(space, SegmentDesignSpace) and bool(space.catch_rows)
    if catching and res.status == DS_OK:
        catch_check(space, res)
    elif catching and diagnose and res.status != OUT_OF_BOUNDS:
        missed = missed_bar(space, values, z0)
        if missed:
            res.status, res.message = DS_NO_CYCLE, missed
    if res.status != DS_OK:
        res.spectral_radius_fd = math.nan
        res.jacobian_fd, res.multipliers_fd = nank.copy(), np.full(k, np.nan)
        if not res.message:
            res.message = f"{STATUS_NAMES[res.status]} (|F| = {info[I_DEFECT]:.3g})"
        return res
    return with_variational(space, res) if variational else res


def clocked_stability(space: DesignSpace, res: DesignResult, robot: Robot,
                      settings: np.ndarray) -> None:
    """A solved gait's stability under a running clock, in place: the stroboscopic map's
    Jacobian at ``res.state`` by finite differences (compiled), its multipliers, and its
    squared defect ``|P(x) - x|^2`` as ``res.error`` (the gait of the restarting clock is
    this map's fixed point: the defect is round-off)."""
    prog, _ = space.cycle_gait(res.values, res.period).program()
    x = res.state
    DP = np.empty((x.size, x.size))
    x_next = np.empty(x.size)
    status, nfev = clocked_jacobian(kernel_method(settings, prog, L.PHASE_SWING), robot.params(),
                                    prog, np.empty((0, L.N_OBS_COLS)),
                                    settings, x, space.fd_step, DP, x_next)
    res.nfev += int(nfev)
    if status != L.ST_OK:
        res.status = DS_STENCIL
        res.message = (f"stencil_failed: a run of the running-clock map ended "
                       f"{L.STATUS_NAMES[int(status)]}")
        return
    res.error = float(np.sum((x_next - x) ** 2))
    res.jacobian_fd = DP
    res.multipliers_fd = sorted_eigs(DP)
    res.spectral_radius_fd = spectral_radius(DP, space.steps)


#: a bar's window [m] wide enough that the first crossing of its height catches it (the
#: robot is shorter): :func:`missed_bar` finds where a design's gait would catch
OPEN_WINDOW = 10.0


def catch_check(space: SegmentDesignSpace, res: DesignResult) -> None:
    """A solved gait's bar catches, in place: each catching segment's offset margin [m] and
    catch speed [m s-1] (:func:`~monkeystudy.analysis.sections.cycle_catches`), and the
    design rejected (status ``out_of_bounds``, the reason in ``message``) when a catch is
    missing or its margin is below ``space.min_offset_margin``."""
    rows = space.catch_rows
    c = cycle_catches(res.z, space.cycle_gait(res.values, res.period),
                      robot=space.robot_for(res.values), integrator=space.integrator)
    margin, speed = np.full(len(rows), np.nan), np.full(len(rows), np.nan)
    for k, seg in enumerate(c.segment):
        if seg in rows:
            margin[rows.index(seg)], speed[rows.index(seg)] = c.margin[k], c.speed[k]
    res.catch_offset_margin, res.catch_speed = margin, speed
    if not np.all(np.isfinite(margin)):
        missing = [rows[i] + 1 for i in np.flatnonzero(~np.isfinite(margin))]
        res.status = OUT_OF_BOUNDS
        res.message = f"out_of_bounds: no catch by segment(s) {missing} in the cycle"
    elif np.min(margin) < space.min_offset_margin:
        i = int(np.argmin(margin))
        res.status = OUT_OF_BOUNDS
        res.message = (f"out_of_bounds: segment {rows[i] + 1}'s catch has an offset margin of "
                       f"{margin[i]:.4g} m, below min_offset_margin "
                       f"{space.min_offset_margin:.4g} m")


def missed_bar(space: SegmentDesignSpace, values: Mapping[str, float], z0) -> str:
    """Whether a design of a bar gait that has no gait misses a bar ('' if not): the
    message of status ``no_cycle``.

    Either the design's gait with every bar's window opened (to :data:`OPEN_WINDOW`) exists
    and catches a bar outside its real window (Newton cannot reach it: the hook passes that
    bar), or the cycle from Newton's start ``z0`` ends at the horizon of a catching
    segment (no crossing of the bar's height inside its window).
    """
    gait = space.gait_for(values)
    opened = replace(space, base_gait=replace(space.base_gait, segments=tuple(
        replace(seg, bar_window=OPEN_WINDOW) if seg.until == "bar" else seg
        for seg in space.base_gait.segments)))
    wide = evaluate_design(opened, {k: v for k, v in values.items()
                                    if k in space.parameter_names}, z0, diagnose=False)
    if wide.ok:
        windows = np.array([gait.segments[k].bar_window for k in space.catch_rows])
        outside = np.flatnonzero(wide.catch_offset_margin - OPEN_WINDOW + windows < 0)
        if outside.size:
            k = int(outside[0])
            off = OPEN_WINDOW - wide.catch_offset_margin[k]
            return (f"{STATUS_NAMES[DS_NO_CYCLE]}: the design's gait catches segment "
                    f"{space.catch_rows[k] + 1}'s bar {off:.4g} m from it, outside its window "
                    f"{windows[k]:g} m: the hook passes that bar")
    res = run_controller(gait.controller(), cycle_section_state(gait, z0),
                         robot=space.robot_for(values), integrator=space.integrator, cycles=1,
                         log_capacity=0)
    seg = int(res.state[L.H_SEG])
    base = (f"{STATUS_NAMES[DS_NO_CYCLE]}: the cycle from the start ends "
            f"{res.status.name.lower()}")
    if res.status == Status.HORIZON and seg in space.catch_rows:
        bar = gait.segments[seg]
        return (f"{base}: the hook passes segment {seg + 1}'s bar, no crossing of its height "
                f"within its window ({bar.bar_window:g} m of {bar.bar_dx:g} m)")
    return ""


def full_map_stability(space: SegmentDesignSpace, res: DesignResult) -> None:
    """A solved gait's stability on the full map (the height included), in place: the
    Jacobian at ``(0, z)`` by fourth-order central differences of
    :func:`~monkeystudy.analysis.cycle_full_map` (the step relative, ``space.fd_step``), its
    multipliers and spectral radius (status ``stencil_failed`` if a run of the stencil left
    the gait)."""
    gait = space.cycle_gait(res.values, res.period)
    fmap = partial(cycle_full_map, gait=gait, robot=space.robot_for(res.values),
                   integrator=space.integrator)
    try:
        J = jacobian_fd(fmap, res.full_state, space.fd_step)
    except RuntimeError as exc:
        res.status = DS_STENCIL
        res.message = f"stencil_failed: the full map's {exc}"
        return
    res.jacobian_fd = J
    res.multipliers_fd = sorted_eigs(J)
    res.spectral_radius_fd = spectral_radius(J, space.steps)


def with_variational(space: DesignSpace, res: DesignResult) -> DesignResult:
    """A solved design's Jacobian, multipliers and spectral radius by variational equations
    with saltation matrices (in place; returns ``res``); of the full map with a space's
    ``height_in_map``."""
    height = space.height_in_map
    J = sequence_variational_jacobian(space.cycle_gait(res.values, res.period),
                                      res.full_state if height else res.state,
                                      robot=space.robot_for(res.values),
                                      integrator=space.integrator, height=height)
    res.jacobian = J
    res.multipliers = sorted_eigs(J)
    res.spectral_radius = spectral_radius(J, space.steps)
    return res


# --- a design is a step ------------------------------------------------------------------------
#: sampling step of the run that checks a design's cycle [s] (a link at 60 rad s-1 turns
#: 0.06 rad between samples)
SHAPE_SAMPLE_DT = 1e-3


@dataclass(frozen=True)
class CycleShape:
    """What one cycle of a gait does, from a run sampled every :data:`SHAPE_SAMPLE_DT`.

    ``status`` is the run's (a :class:`~monkeystudy.simulation.Status` value), ``swaps`` the
    changes of the attached end, ``crossings`` the passes of link 1 through the section's
    angle, the one that closes the cycle included; ``max_abs_theta2`` [rad] the largest
    ``|theta2|`` (``pi``: link 2 folded onto link 1) and ``max_kinetic_energy`` [J] the
    largest kinetic energy of the samples.
    """

    status: int
    swaps: int
    crossings: int
    max_abs_theta2: float
    max_kinetic_energy: float


def cycle_shape(gait: SequenceGait, z, *, robot: Robot, integrator: Integrator,
                sample_dt: float = SHAPE_SAMPLE_DT) -> CycleShape:
    """One cycle of ``gait`` from the section state ``z`` (theta2 [rad], dtheta1, dtheta2
    [rad s-1]) on ``robot``, and what it did (:class:`CycleShape`). A crossing is a change
    of sign of ``theta1 - section_theta1`` between samples in the same frame (the frame
    flips at a swap); samples on the section (within 1e-9 rad) do not count, so the start
    and the end, which lie on it, add none: the end adds the closing crossing."""
    res = run_controller(gait.controller(), cycle_section_state(gait, z), robot=robot,
                         integrator=integrator, cycles=1, sample_dt=sample_dt)
    states = res.sample_state
    flipped = res.sample_mode[:, L.M_FLIPPED]
    off = states[:, L.TH1] - gait.section_theta1
    away = np.abs(off) > 1e-9
    side, frame = np.sign(off[away]), flipped[away]
    crossings = int(np.sum((side[1:] != side[:-1]) & (frame[1:] == frame[:-1])))
    kinetic, _ = energies(res.params, states, flipped)
    return CycleShape(int(res.status), int(np.sum(flipped[1:] != flipped[:-1])),
                      crossings + 1, float(np.max(np.abs(states[:, L.TH2]))),
                      float(np.max(kinetic)))


def step_problems(shape: CycleShape, reference: CycleShape, robot: Robot,
                  steps: int = 1) -> list[str]:
    """Why a cycle (``shape``, ``steps`` steps of a design on ``robot``) is not a gait of its
    starting gait's kind (``reference``, one step); empty if it is.

    A step of the starting gait's kind swaps magnets as often and passes link 1 through the
    section as often, per step (a schedule event after the step's own return to the section,
    e.g. a pulse longer than the step, adds passes); keeps ``|theta2| < pi`` (link 2 never
    turns through link 1: theta2 stays within one turn); and swings rather than spins: its
    kinetic energy stays below ``M g (L1 + L2)``, what lifting the whole robot by its
    length takes.
    """
    if shape.status != 0:
        return [f"its cycle from the fixed point ends {Status(shape.status).name}"]
    out = []
    if shape.swaps != steps * reference.swaps:
        out.append(f"{shape.swaps} swaps per cycle, the starting gait "
                   f"{steps * reference.swaps}")
    if shape.crossings != steps * reference.crossings:
        out.append(f"link 1 passes the section {shape.crossings} times per cycle, the "
                   f"starting gait {steps * reference.crossings}")
    if not shape.max_abs_theta2 < math.pi:
        out.append(f"|theta2| reaches {shape.max_abs_theta2:.4g} rad: link 2 turns through "
                   "link 1")
    mass = robot.link1.mass + robot.link2.mass
    lift = mass * robot.gravity * (robot.link1.length + robot.link2.length)
    if not shape.max_kinetic_energy < lift:
        out.append(f"kinetic energy {shape.max_kinetic_energy:.4g} J, above M g (L1 + L2) "
                   f"= {lift:.4g} J: a link spins")
    return out


def design_step_problem(space: DesignSpace, res: DesignResult, reference: CycleShape) -> str:
    """Why a solved design is not a gait of its starting gait's kind (:func:`step_problems`
    of its cycle from its fixed point, on the clock that restarts at the section: a running
    clock's gait is the same orbit); '' if it is one."""
    robot = space.robot_for(res.values)
    shape = cycle_shape(space.gait_for(res.values), res.z, robot=robot,
                        integrator=space.integrator)
    return "; ".join(step_problems(shape, reference, robot, space.steps))


# --- verification of a design ------------------------------------------------------------------
@dataclass
class Replay:
    """A design's gait run open loop for many cycles from its fixed point (per cycle)."""

    tick: float              # [s] (0: exact timing)
    error: np.ndarray        # section error against the fixed point
    kinetic_energy: np.ndarray   # [J] at each section crossing
    pivot_height: np.ndarray     # [m]
    cycles_completed: int    # cycles before it fell, stopped, or left the error bound
    status: int
    cycles_walked: int = 0   # cycles before it fell, stopped or advanced < half a gait cycle


def replay_design(space: DesignSpace, result: DesignResult, *, cycles: int,
                  tick: float = 0.0, error_bound: float = 1e-2, start=None) -> Replay:
    """Run the design's schedule open loop (its clock restarting at each vertical crossing or
    running on, actions on the ``tick`` grid [s]) for up to ``cycles`` cycles from ``start``
    (default: the fixed point, :attr:`DesignResult.state`); ``cycles_completed`` counts the
    cycles before the run fell or stopped, or its error against the fixed point first
    exceeded ``error_bound``; ``cycles_walked`` counts the cycles before it fell or stopped
    or a cycle advanced less than half the gait's advance, whatever its error (on the tick a
    stable gait walks on near its orbit, the tick's delays keeping its error up)."""
    robot = space.robot_for(result.values)
    gait = space.cycle_gait(result.values, result.period)
    z0 = result.state if start is None else np.asarray(start, float)
    run = sequence_cycles(gait, z0, cycles=cycles, robot=robot, integrator=space.integrator,
                          reference=result.state, tick=tick)
    bound = cycles_to_bound(run.error, error_bound)
    completed = bound - 1 if run.error.size and not run.error[bound - 1] <= error_bound else bound
    short = np.flatnonzero(~(run.x_advance * math.copysign(1.0, result.advance)
                             >= 0.5 * abs(result.advance)))
    walked = int(short[0]) if short.size else int(run.error.size)
    return Replay(tick, run.error, run.kinetic_energy, run.pivot_height, int(completed),
                  int(run.status), walked)


def perturbation_decay(space: DesignSpace, result: DesignResult, *, size: float = 1e-3,
                       cycles: int = 60) -> tuple[np.ndarray, float]:
    """The distance ``|z_k - z*|`` per cycle from a start ``size`` away from the fixed point
    along the leading eigenvector (real part, unit length), exact timing, and the growth per
    cycle fitted to it (:func:`~monkeystudy.analysis.replay.growth_per_cycle`; compare with
    ``rho ** steps``)."""
    # with the height in the map the replay starts at the start's height: perturb the
    # section state along the section map's leading direction
    J = result.jacobian_fd[1:, 1:] if space.height_in_map else result.jacobian_fd
    lam, vec = np.linalg.eig(J)
    v = np.real(vec[:, int(np.argmax(np.abs(lam)))])
    v /= np.linalg.norm(v)
    rep = replay_design(space, result, cycles=cycles, start=result.state + size * v,
                        error_bound=math.inf)
    dist = np.sqrt(rep.error)
    return dist, growth_per_cycle(rep.error, window=(1e-9, 10 * size))


def design_basin(space: DesignSpace, result: DesignResult, offsets1, offsets2, *,
                 max_cycles: int, error_bound: float = 1e-2) -> np.ndarray:
    """Cycles survived from the fixed point offset by ``(d dtheta1, d dtheta2)`` [rad s-1]
    (:func:`~monkeystudy.analysis.replay.sequence_basin`, exact timing)."""
    robot = space.robot_for(result.values)
    return sequence_basin(space.cycle_gait(result.values, result.period), result.state,
                          offsets1, offsets2, max_cycles=max_cycles, error_bound=error_bound,
                          robot=robot, integrator=space.integrator)


def design_survival(space: DesignSpace, result: DesignResult, *, runs: int, max_cycles: int,
                    noise: Noise, seed: int, tick: float,
                    min_advance_fraction: float = 0.5,
                    progress: Callable[[int], None] | None = None) -> SurvivalRuns:
    """Runs ``0 .. runs - 1`` of the design's gait from its fixed point under ``noise``
    (:func:`~monkeystudy.analysis.survival.survival_runs`, drawn with ``seed``), on the
    controller ``tick`` [s], each until it fails or completes ``max_cycles``; a cycle whose
    attached end advances less than ``min_advance_fraction`` of the gait's advance stalls the
    run, the advance measured the way the gait travels (a ladder gait may go towards -x).
    The design's own gait: a schedule runs on time, a sequence gait by its guards.
    ``progress(1)`` as each run ends (:func:`~monkeystudy.analysis.survival.survival_runs`)."""
    gait = replace(space.cycle_gait(result.values, result.period),
                   theta2=float(result.z[0]), tick=float(tick))
    return survival_runs(gait.loop_controller(), cycle_section_state(gait, result.state),
                         result.z, runs=np.arange(int(runs)), max_cycles=int(max_cycles),
                         noise=noise, seed=int(seed), robot=space.robot_for(result.values),
                         integrator=space.integrator,
                         min_advance=min_advance_fraction * abs(result.advance),
                         travel=-1.0 if result.advance < 0.0 else 1.0,
                         section=gait.section_observers(), progress=progress)


def design_cycle_run(space: DesignSpace, result: DesignResult, *, sample_dt: float):
    """One cycle of the design's gait from its fixed point, sampled every ``sample_dt`` [s]
    (a :class:`~monkeystudy.simulation.RunResult`, for the filmstrip)."""
    gait = space.cycle_gait(result.values, result.period)
    return run_controller(gait.controller(), cycle_section_state(gait, result.state),
                          robot=space.robot_for(result.values), integrator=space.integrator,
                          cycles=1, sample_dt=sample_dt)
