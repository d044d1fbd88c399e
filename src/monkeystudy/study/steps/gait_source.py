"""Where a step's gait comes from: the one module that reads what earlier steps hand on.

A step names its source in ``from:``; the source's kind hands it on
(:meth:`~monkeystudy.study.steps.base.StepKind.hand_on`) through the readers here: a
:class:`GaitStart` from a refine, shoot, floquet or design step, the best minima of a grid
step. Every kind gets its start from one of them, whatever the study's gait (the horizontal
gait is a sequence gait, :func:`~monkeystudy.controllers.horizontal_gait`), and names it in
its dataset by :meth:`GaitStart.attrs`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
import netCDF4
import numpy as np

from ...analysis.design import PARAMETERS, DesignSpace, SegmentDesignSpace
from ...analysis.replay import cycle_times
from ...controllers import SequenceGait, motorless, open_loop_gait
from ...robot import Robot
from ...simulation import STATUS_NAMES, Status
from .. import datasets as D
from ..errors import RunFailed
from ..spec import mirror_problem

#: a floquet step's point is run when the return map moves it less than this [1]
MAX_MAP_DEFECT = 1e-8

#: shoot ``method`` flag values (dataset variable ``method``) and their names
METHOD_GAUSS_NEWTON, METHOD_GRAZING = 0, 1
METHOD_NAMES = ("gauss_newton", "grazing")


@dataclass(frozen=True)
class GaitStart:
    """A gait as a step starts from it: what it runs, from where, and how it was found.

    Attributes
    ----------
    gait : SequenceGait
        The gait's program: the study's gait (without its motor for a schedule whose motor
        phase lasts no time), or a design's.
    z : tuple of float
        The section state ``(theta2 [rad], dtheta1, dtheta2 [rad s-1])``; with a running
        clock ``(theta1, theta2, dtheta1, dtheta2)`` at clock phase zero.
    robot : Robot
        The robot it runs on (the study's, or a design's).
    times : tuple of float or None
        The recorded segment exit times [s] an open-loop replay keeps (None: the gait's own
        cycle from ``z``).
    replay : {"gait", "open_loop"}
        How a multi-cycle step runs it.
    clock : str
        Its open-loop clock as datasets name it (``reset_at_vertical``, ``run_on``,
        ``reset_at_section``).
    found_by : str
        How its source found it: ``refine``, ``shoot_grazing``, ``shoot_gauss_newton``,
        ``floquet`` (a fixed point polished by Newton, or a shoot's gait analysed) or
        ``design``.
    swap_motor_times : bool
        The study's datasets name cycle times the 2009 way (:class:`~monkeystudy.study.models.
        Conventions`).
    source : dict
        Where it came from: ``step`` (the source step's name), ``kind`` and, as the source
        has them, ``index`` (solution or refine start), ``error`` (its gait error),
        ``map_defect``, ``newton_converged``, ``controller`` (a floquet return map),
        ``method`` (a shoot method), ``t_switch``, ``t_motor``, ``t_end`` [s] (the recorded
        schedule), ``vertical_passes``, ``spectral_radius``, ``status``.
    """

    gait: SequenceGait
    z: tuple
    robot: Robot
    times: tuple | None
    replay: str
    clock: str
    found_by: str
    swap_motor_times: bool
    source: dict = field(default_factory=dict)

    @property
    def period(self) -> float:
        """The running clock's period [s] (NaN: the clock restarts at each cycle's end)."""
        return self.gait.period

    @property
    def torque(self) -> float:
        """The gait's motor torque [N m] (0: it never runs its motor)."""
        return motor_torque_of(self.gait)

    def schedule(self, integrator) -> np.ndarray:
        """The segment exit times [s] an open-loop replay keeps: the recorded ones, else the
        gait's own cycle from ``z``."""
        if self.times is not None:
            return np.asarray(self.times, float)
        return cycle_times(self.gait, self.z, robot=self.robot, integrator=integrator)

    def program(self, tick: float, integrator) -> SequenceGait:
        """The gait as it is run: its open-loop replay (:func:`~monkeystudy.controllers.
        open_loop_gait`) or its own controller, from ``z``'s theta2, on the controller
        ``tick`` [s]. A design's gait is its open-loop schedule already."""
        gait = self.gait
        if self.replay == "open_loop" and self.found_by != "design":
            gait = open_loop_gait(gait, self.schedule(integrator))
        return replace(gait, theta2=float(self.z[-3]), tick=float(tick))

    # --- how datasets name it -----------------------------------------------------------------
    def attrs(self, form: str, **run) -> dict:
        """The attributes naming this start in a dataset, as each form of step names it.

        ``run`` (stability, tick_sweep, basin: what ran), ``analysis`` (floquet,
        continuation: what was analysed), ``source`` (design: where it came from),
        ``survival`` (the source and the schedule run). ``run`` values a step measured (its
        replayed ``t_segment`` [s], ``open_loop_multipliers``) join a per-segment record.
        """
        src = self.source
        step_key = f"{src['kind']}_step"
        if form == "analysis":
            if src["kind"] == "shoot":
                return self._shoot_attrs()
            if src["kind"] == "refine":
                return {step_key: src["step"], "refine_start": int(src["index"]),
                        "dtheta1": self.z[-2], "dtheta2": self.z[-1],
                        "gait_error": src["error"]}
            return {step_key: src["step"], "fixed_point": [float(v) for v in self.z],
                    "map_defect": src["map_defect"]}
        if not self.swap_motor_times:
            out = self._section_attrs()
            if form == "run":
                if "t_segment" in run:
                    out["t_segment"] = [float(t) for t in run["t_segment"]]
                lam = run.get("open_loop_multipliers")
                if lam is not None:
                    lam = np.asarray(lam, complex)
                    out.update(open_loop_multipliers_real=lam.real.tolist(),
                               open_loop_multipliers_imag=lam.imag.tolist())
            elif form == "survival" and "t_segment" in run:
                out["t_segment"] = [float(t) for t in run["t_segment"]]
            return out
        if form == "run":
            if src["kind"] == "shoot":
                return dict(self._shoot_attrs(), replay=self.replay)
            out = self._origin_attrs()
            out.update(replay=self.replay, t_switch=src["t_switch"], t_motor=src["t_motor"])
            if src["kind"] == "refine":
                out["vertical_passes_before_swap"] = int(src.get("vertical_passes", -1))
                del out["gait_error"]
            return out
        out = self._origin_attrs()
        if form == "survival":
            out.update(t_switch=src["t_switch"], t_motor=src["t_motor"],
                       motor_torque=src["torque"])
        return out

    def _shoot_attrs(self) -> dict:
        src = self.source
        return {"shoot_step": src["step"], "solution": int(src["index"]),
                "dtheta1": self.z[-2], "dtheta2": self.z[-1], "t_switch": src["t_switch"],
                "t_motor": src["t_motor"], "gait_error": src["error"],
                "gait_method": src["method"]}

    def _origin_attrs(self) -> dict:
        """Where it came from, as survival and design datasets name it."""
        src = self.source
        kind = src["kind"]
        if kind == "shoot":
            return {"shoot_step": src["step"], "solution": int(src["index"]),
                    "gait_error": src["error"]}
        if kind == "refine":
            return {"refine_step": src["step"], "refine_start": int(src["index"]),
                    "gait_error": src["error"]}
        if kind == "floquet":
            return {"floquet_step": src["step"], "floquet_controller": src["controller"],
                    "map_defect": src["map_defect"],
                    "newton_converged": int(src["newton_converged"])}
        return {"design_step": src["step"], "design_spectral_radius": src["spectral_radius"],
                "gait_error": src["error"]}

    def _section_attrs(self) -> dict:
        """A start named on its section (a gait whose times are named per segment)."""
        src = self.source
        out = {"replay": self.replay, f"{src['kind']}_step": src["step"],
               "start_theta2": float(self.z[-3]), "dtheta1": float(self.z[-2]),
               "dtheta2": float(self.z[-1]), "section_theta1": float(self.gait.section_theta1)}
        if src["kind"] == "refine":
            out.update(refine_start=int(src["index"]), gait_error=float(src["error"]))
        elif src["kind"] == "design":
            out.update(design_spectral_radius=float(src["spectral_radius"]),
                       gait_error=float(src["error"]))
        else:
            out["map_defect"] = float(src["map_defect"])
        return out


def motor_torque_of(gait: SequenceGait) -> float:
    """A gait's reference motor torque [N m]: its first non-zero segment torque (the
    section's last); 0 when it never runs its motor."""
    for seg in gait.segments:
        if seg.torque != 0.0:
            return float(seg.torque)
    return float(gait.section_torque)


def no_start_attrs(source: str | None) -> dict:
    """The attributes of an analysis that started from no earlier step's gait."""
    return {"shoot_step": source or "", "solution": -1}


def gait_line(a) -> str:
    """One line naming the gait a dataset's attributes say it used: a shoot step's solution
    or a refine step's start."""
    if "refine_step" in a and "refine_start" in a:
        return (f"gait: start {a.get('refine_start')} of refine step {a.get('refine_step')!r}, "
                f"({float(a['dtheta1']):.10g}, {float(a['dtheta2']):.10g}) rad s-1, error "
                f"{float(a['gait_error']):.3g}")
    if int(a.get("solution", -1)) < 0:
        return "no shoot gait used"
    return (f"gait: solution {a.get('solution')} of {a.get('shoot_step')!r} "
            f"({a.get('gait_method')}), ({float(a['dtheta1']):.10g}, "
            f"{float(a['dtheta2']):.10g}) rad s-1, t_switch {float(a['t_switch']):.6g} s, "
            f"t_motor {float(a['t_motor']):.6g} s, error {float(a['gait_error']):.3g}")


def option_problems(step, ref, index: int) -> list:
    """Problems with a step's choice of its source's gait: ``solution`` picks a shoot step's,
    ``start_index`` a refine step's start (``ref``: the source step, when of a kind the step
    accepts)."""
    out = []
    if ref is None:
        return out
    one = "; a floquet step has one fixed point" if ref.kind == "floquet" else ""
    if getattr(step, "solution", None) is not None and ref.kind != "shoot":
        out.append((("steps", index, "solution"), "solution picks a shoot step's solution"
                    + one))
    start_index = getattr(step, "start_index", None)
    if start_index is not None:
        if ref.kind != "refine":
            out.append((("steps", index, "start_index"), "start_index picks a refine "
                        "step's start" + one))
        elif start_index >= ref.n_starts:
            out.append((("steps", index, "start_index"),
                        f"must be < {ref.n_starts} (the starts of {ref.name!r})"))
    return out


def run_problems(study, index: int, step, ref, replays: bool = True) -> list:
    """Problems with how a multi-cycle step runs its source's gait: a replay and a clock the
    study's gait accepts (:class:`~monkeystudy.study.models.Conventions`), its choice of the
    source's gait (:func:`option_problems`), and mirror-image links when a cycle ends on end
    B (each cycle is measured in the frame of the end it ends on). ``replays``: check the
    replay against the ones the gait accepts (a step with rules of its own does not)."""
    conv = study.gait.conventions
    out = []
    replay = getattr(step, "replay", None)
    if replays and replay is not None and replay not in conv.replays:
        out.append((("steps", index, "replay"), f"the {conv.name} is replayed open-loop "
                    f"(replay: {replay} needs a sequence gait)"))
    resets = [k for k, seg in enumerate(study.gait.gait().segments) if seg.clock != "keep"]
    if (replay or conv.replay) == "open_loop" and resets and (ref is None
                                                              or ref.kind != "design"):
        out.append((("steps", index, "replay"), f"an open-loop replay ends every segment at "
                    f"its recorded time on the clock of the cycle's start, and segment "
                    f"{resets[0]} resets the clock (clock: reset): replay: gait"))
    controller = getattr(step, "controller", None)
    if controller is not None and controller.clock not in conv.clocks:
        out.append((("steps", index, "controller", "clock"), f"a {conv.name}'s clock "
                    "restarts at each section crossing (reset_at_vertical)"))
    if study.gait.gait().end_attached() == "B":
        problem = mirror_problem(study.to_robot())
        if problem:
            out.append((("steps", index, "kind"), f"a {step.kind} step {problem}"))
    return out + option_problems(step, ref, index)


# --- what each kind of source hands on ----------------------------------------------------------
@dataclass(frozen=True)
class StartRequest:
    """What a step asks of its source (every field optional; each source uses its own).

    Attributes
    ----------
    solution : int or None
        A shoot step's solution (default: the lowest-error usable one).
    grazing : bool
        Only a converged grazing solution of a shoot step will do.
    start_index : int or None
        A refine step's start (default: the lowest error).
    replay : str or None
        ``gait`` or ``open_loop`` (default: the study's gait's, :class:`~monkeystudy.study.
        models.Conventions`).
    clock : str
        ``reset_at_vertical`` or ``run_on`` (a clock running on with the gait's period).
    max_map_defect : float or None
        A floquet step's point is also run when the return map moves it less than this [1],
        its Newton polish converged or not (default: only when Newton converged).
    require : str or None
        Refuse a start whose cycle failed, saying what the step would do (``run``,
        ``analyse``, ``continue``); None: hand it on (the step records the failure).
    best : int
        How many minima of a grid step.
    """

    solution: int | None = None
    grazing: bool = False
    start_index: int | None = None
    replay: str | None = None
    clock: str = "reset_at_vertical"
    max_map_defect: float | None = None
    require: str | None = None
    best: int = 1


def _replay_and_clock(req: StartRequest, conventions) -> tuple[str, str]:
    """The replay a start is run by and its clock's name."""
    return (req.replay or conventions.replay,
            conventions.clock if req.clock == "reset_at_vertical" else req.clock)


def refine_start(path: Path, name: str, ctx, req: StartRequest) -> GaitStart:
    """The gait of a refine dataset: its lowest-error start (or ``req.start_index``), at the
    section's theta2, with its recorded swap and motor times when the study names them so
    (with ``req.require``, refused when its cycle failed)."""
    g, idx = read_refined(path, req.start_index)
    if req.require is not None and (g["status"] != Status.OK or not math.isfinite(g["error"])):
        raise RunFailed(f"{ctx.name}: refine step {name!r} found no gait to {req.require} "
                        f"(status {STATUS_NAMES[g['status']]})")
    spec = ctx.spec
    replay, clock_name = _replay_and_clock(req, ctx.conventions)
    gait = spec.sequence
    z = (gait.theta2, g["dtheta1"], g["dtheta2"])
    times = None
    if spec.swap_motor_times:
        times = (g["t_switch"], g["t_switch"] + g["t_motor"])
        if req.clock == "run_on":
            gait, z = replace(gait, period=g["t_end"]), (gait.section_theta1, *z)
    source = {"step": name, "kind": "refine", "index": idx, "error": g["error"],
              "t_switch": g["t_switch"], "t_motor": g["t_motor"], "t_end": g["t_end"],
              "vertical_passes": int(g.get("vertical_passes", -1)) if
              math.isfinite(g.get("vertical_passes", math.nan)) else -1,
              "status": g["status"], "torque": motor_torque_of(gait)}
    return GaitStart(gait, z, spec.robot, times, replay, clock_name, "refine",
                     spec.swap_motor_times, source)


def shoot_start(path: Path, name: str, ctx, req: StartRequest) -> GaitStart:
    """The gait of a shoot dataset: its lowest-error usable solution (or ``req.solution``; a
    converged grazing one with ``req.grazing``), replayed open-loop with its recorded times
    (without the motor when its motor phase lasts no time)."""
    g = pick_solution(read_shoot(path), ctx.name, name, req.solution, req.grazing)
    spec = ctx.spec
    gait = spec.sequence if g["t_motor"] != 0.0 else motorless(spec.sequence)
    z = (gait.theta2, g["dtheta1"], g["dtheta2"])
    if req.clock == "run_on":
        gait, z = replace(gait, period=g["t_end"]), (gait.section_theta1, *z)
    method = METHOD_NAMES[g["method"]]
    source = {"step": name, "kind": "shoot", "index": g["index"], "error": g["error"],
              "method": method, "t_switch": g["t_switch"], "t_motor": g["t_motor"],
              "t_end": g["t_end"], "status": g["status"], "torque": motor_torque_of(gait)}
    return GaitStart(gait, z, spec.robot, (g["t_switch"], g["t_switch"] + g["t_motor"]),
                     "open_loop", _replay_and_clock(req, ctx.conventions)[1],
                     f"shoot_{method}", spec.swap_motor_times, source)


def floquet_start(path: Path, name: str, ctx, req: StartRequest) -> GaitStart:
    """The fixed point of a floquet dataset a step runs: the open_loop return map's (with
    its recorded times) for an open-loop replay when the step analysed one, else the gait's
    own controller's. Refused (:class:`~monkeystudy.study.errors.RunFailed`) unless finite
    and polished: Newton converged or, given ``max_map_defect`` [1], the map moves it less
    (a neutral multiplier can leave Newton short of its tolerance at a point that is a fixed
    point to the map's accuracy; ``req.max_map_defect``). An open-loop replay of the gait's
    own cycle keeps the analysed cycle's segment exits (exact timing, whatever the gait's
    tick). With ``req.clock`` ``run_on`` the clock runs on with the period of the analysed
    cycle from the fixed point (its section crossing, exact timing), the start at clock phase
    zero."""
    spec = ctx.spec
    replay, clock_name = _replay_and_clock(req, ctx.conventions)
    labels = floquet_controllers(path)
    controller = ("open_loop" if replay == "open_loop" and "open_loop" in labels else
                  next((c for c in ("sequence", "search") if c in labels), labels[0]))
    fp = read_floquet_point(path, controller)
    if fp["failure"]:
        raise RunFailed(f"{ctx.name}: floquet step {name!r} could not analyse its "
                        f"{controller} return map: {fp['failure']}")
    z = tuple(float(v) for v in fp["fixed_point"])
    close = fp["newton_converged"] != 0 or (req.max_map_defect is not None
                                             and fp["map_defect"] <= req.max_map_defect)
    if not (np.all(np.isfinite(z)) and close):
        newton = ("converged" if fp["newton_converged"] else
                  fp["newton_stop"] or "not converged")
        raise RunFailed(f"{ctx.name}: floquet step {name!r} has no {controller} fixed point "
                        f"to {req.require or 'run'} (map defect {fp['map_defect']:.3g}, Newton "
                        f"{newton})")
    gait, times = spec.sequence, None
    if controller == "open_loop":
        gait = gait if fp["motor_torque"] != 0.0 else motorless(gait)
        times = (fp["t_switch"], fp["t_switch"] + fp["t_motor"])
    elif replay == "open_loop":
        # the schedule an open-loop replay keeps is the analysed cycle's, exact timing (the
        # fixed point is the exact-timing map's; a replay on a tick puts it on the tick)
        times = tuple(float(t) for t in cycle_times(replace(gait, tick=0.0), z,
                                                    robot=spec.robot,
                                                    integrator=spec.integrator))
    t_end = math.nan
    if req.clock == "run_on":
        # the period is the analysed cycle's: the fixed point's section crossing, exact timing
        cycle = gait if times is None else open_loop_gait(gait, times)
        t_end = float(cycle_times(replace(cycle, tick=0.0), z, robot=spec.robot,
                                  integrator=spec.integrator)[-1])
        gait, z = replace(gait, period=t_end), (gait.section_theta1, *z)
    source = {"step": name, "kind": "floquet", "controller": controller,
              "map_defect": fp["map_defect"], "newton_converged": fp["newton_converged"],
              "t_switch": fp["t_switch"], "t_motor": fp["t_motor"], "t_end": t_end,
              "torque": motor_torque_of(gait)}
    return GaitStart(gait, z, spec.robot, times, replay, clock_name, "floquet",
                     spec.swap_motor_times, source)


def design_start(path: Path, name: str, ctx, req: StartRequest) -> GaitStart:
    """The best design of a design dataset: its own schedule (an open-loop gait) and robot,
    from its fixed point; of a sequence gait's design, the gait with the best design's
    segment values, run as the study's gait runs."""
    a = D.read_attrs(path) or {}
    z = (float(a["best_theta2"]), float(a["best_dtheta1"]), float(a["best_dtheta2"]))
    if "best_segment1_value" in a:   # a design of a sequence gait's segments
        spec = ctx.spec
        space = SegmentDesignSpace(spec.sequence, spec.robot,
                                   motor_frame=spec.torque_frame == "motor")
        values = {n: float(a[f"best_{n}"]) for n in space.parameter_names}
        replay, clock_name = _replay_and_clock(req, ctx.conventions)
        source = {"step": name, "kind": "design", "error": float(a["best_error"]),
                  "spectral_radius": float(a["best_spectral_radius"]),
                  "t_switch": math.nan, "t_motor": math.nan, "torque": math.nan}
        return GaitStart(space.gait_for(values), z, spec.robot, None, replay, clock_name,
                         "design", spec.swap_motor_times, source)
    values = {n: float(a[f"best_{n}"]) for n in PARAMETERS}
    space = DesignSpace(ctx.spec.robot, two_step=int(a["steps_per_cycle"]) == 2,
                        balance="none")
    source = {"step": name, "kind": "design", "error": float(a["best_error"]),
              "spectral_radius": float(a["best_spectral_radius"]),
              "t_switch": values["t_switch"], "t_motor": values["t_motor"],
              "torque": values["torque"]}
    return GaitStart(space.gait(values), z, space.robot_for(values), None, "open_loop",
                     "reset_at_vertical", "design", ctx.spec.swap_motor_times, source)


def grid_minima(path: Path, name: str, ctx, req: StartRequest) -> np.ndarray:
    """The ``req.best`` starts a grid dataset hands on, ``[best, 2]`` (dtheta1, dtheta2)
    [rad s-1] (:func:`best_grid_points`).

    A grid with fewer points with a gait error than ``best`` is refused (``RunFailed``): the
    step's starts, and so its tasks and its dataset's ``start`` dimension, are fixed by
    ``best`` before the grid runs."""
    v = D.read_variables(path, ("error", "dtheta1", "dtheta2"))
    try:
        return best_grid_points(v["error"], v["dtheta1"], v["dtheta2"], req.best)
    except ValueError as exc:
        raise RunFailed(f"{ctx.name}: start: {{from: {name}, best: {req.best}}}: grid "
                        f"{name!r}: {exc}") from None


# --- the datasets' readers -----------------------------------------------------------------------
def best_grid_points(error: np.ndarray, d1: np.ndarray, d2: np.ndarray, k: int) -> np.ndarray:
    """The ``k`` best starts of a grid, ``[k, 2]``: local minima of the error map (no finite
    8-neighbour lower), lowest first, then the lowest remaining points; ties by flat index.

    Fewer than ``k`` points with an error value (a gait) is a ``ValueError`` saying how many
    there are."""
    e = np.asarray(error, np.float64)
    finite = np.isfinite(e)
    n = int(finite.sum())
    if n < k:
        if n == 0:
            have = ("its one point has no gait" if e.size == 1 else
                    f"none of its {e.size} points has a gait")
            raise ValueError(f"{k} start{'s' if k > 1 else ''} requested, but {have} (no "
                             "error value; its status says why): widen or move the grid")
        raise ValueError(f"{k} starts requested, but only {n} of its {e.size} points "
                         f"{'has' if n == 1 else 'have'} a gait (an error value): ask for at "
                         f"most {n}, or widen or move the grid")
    if e.ndim == 2:
        big = np.where(finite, e, np.inf)
        pad = np.pad(big, 1, constant_values=np.inf)
        local = finite.copy()
        n1, n2 = e.shape
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                if di or dj:
                    local &= big <= pad[1 + di:1 + di + n1, 1 + dj:1 + dj + n2]
        g1, g2 = np.meshgrid(d1, d2, indexing="ij")
        pts = np.stack([g1.ravel(), g2.ravel()], axis=1)
        local = local.ravel()
    else:
        pts = np.stack([d1, d2], axis=1)
        local = np.zeros(e.size, bool)
    flat = e.ravel()
    idx = np.arange(flat.size)
    fin = np.isfinite(flat)
    order_local = idx[local][np.lexsort((idx[local], flat[local]))]
    rest = idx[fin & ~local]
    order_rest = rest[np.lexsort((rest, flat[rest]))]
    chosen = np.concatenate([order_local, order_rest])[:k]
    return pts[chosen]


def read_refined(path: Path, start_index: int | None = None) -> tuple[dict, int]:
    """The refined gait of a refine dataset: ``({dtheta1, dtheta2, t_switch, t_motor, t_end,
    error, status, vertical_passes}, start index)`` (times NaN when the dataset names them per
    segment); for a multi-start dataset the given start or the lowest error."""
    keys = ("dtheta1", "dtheta2", "t_switch", "t_motor", "t_end", "error", "status",
            "vertical_passes")
    vals = D.read_variables(path, keys)
    if start_index is None:
        err = np.where(np.isfinite(vals["error"]), vals["error"], np.inf)
        start_index = int(np.argmin(err))
    g = {k: float(v[start_index]) for k, v in vals.items()}
    for k in keys:
        g.setdefault(k, math.nan)
    g["status"] = int(g["status"])
    return g, start_index


def read_shoot(path: Path) -> list[dict]:
    """The solutions of a shoot dataset: ``[{dtheta1, dtheta2, t_switch, t_motor, t_end,
    error, residual_norm, converged, method, status, index}, ...]`` (solution order)."""
    keys = ("dtheta1", "dtheta2", "t_switch", "t_motor", "t_end", "error", "residual_norm",
            "converged", "method", "status")
    vals = D.read_variables(path, keys)
    out = []
    for i in range(len(vals["dtheta1"])):
        d = {k: float(vals[k][i]) for k in keys}
        for k in ("converged", "method", "status"):
            d[k] = int(d[k])
        d["index"] = i
        out.append(d)
    return out


#: a shoot solution whose gait error is above this is no gait [rad2 + rad2 s-2] (the error
#: bound multi-cycle steps use by default): a grazing solve can converge to a collisionless
#: swap on a later swing, after the cycle's return to the vertical
NOT_A_GAIT = 1e-2


def usable(g: dict, grazing: bool) -> bool:
    """A shoot solution a later step can run: a gait with finite rates and times and an error
    within :data:`NOT_A_GAIT` (a converged grazing one, with ``grazing``)."""
    keys = ("dtheta1", "dtheta2", "t_switch", "t_motor", "error")
    ok = (g["status"] == 0 and all(math.isfinite(g[k]) for k in keys)
          and g["error"] <= NOT_A_GAIT)
    if grazing:
        ok = ok and g["method"] == METHOD_GRAZING and g["converged"] == 1
    return ok


def pick_solution(sols: list[dict], step: str, source: str, solution: int | None,
                  grazing: bool = False) -> dict:
    """The solution a step uses from shoot step ``source``: ``solution``, else the
    lowest-error usable one (:class:`~monkeystudy.study.errors.RunFailed` when none)."""
    what = "converged grazing gait" if grazing else "usable gait"
    if solution is not None:
        if solution >= len(sols):
            raise RunFailed(f"{step}: solution {solution} requested, shoot step {source!r} "
                            f"found {len(sols)}")
        g = sols[solution]
        if not usable(g, grazing):
            raise RunFailed(f"{step}: solution {solution} of shoot step {source!r} is not a "
                            f"{what} (status {g['status']}, error {g['error']:.3g}, method "
                            f"{METHOD_NAMES[g['method']]}, converged {g['converged']}; a "
                            f"gait's error is at most {NOT_A_GAIT:g})")
        return g
    good = [g for g in sols if usable(g, grazing)]
    if not good:
        found = "; ".join(f"{METHOD_NAMES[g['method']]} error {g['error']:.3g} status "
                          f"{g['status']}" for g in sols) or "nothing"
        raise RunFailed(f"{step}: shoot step {source!r} produced no {what} (found: {found}; "
                        f"a gait's error is at most {NOT_A_GAIT:g})")
    return min(good, key=lambda g: (g["error"], g["index"]))


def floquet_controllers(path: Path) -> list[str]:
    """The return maps a floquet dataset analysed, in its order."""
    with netCDF4.Dataset(path, "r") as nc:
        nc.set_auto_mask(False)
        return [str(x) for x in np.atleast_1d(nc.variables["controller"][...])]


def controller_row(nc, path: Path, controller: str) -> int:
    """The row of ``controller`` in an open floquet dataset ``nc`` (read from ``path``)."""
    labels = [str(x) for x in np.atleast_1d(nc.variables["controller"][...])]
    if controller not in labels:
        raise ValueError(f"{Path(path).name} has no {controller} controller")
    return labels.index(controller)


def read_floquet_point(path: Path, controller: str) -> dict:
    """One controller's analysed point of a floquet dataset: ``{fixed_point (3,), map_defect,
    newton_converged, newton_stop, t_switch, t_motor [s], motor_torque [N m], failure}``
    (``newton_converged`` -1 when the dataset has none; ``newton_stop`` why Newton stopped,
    empty when the dataset has none; the times NaN for a gait named per segment; ``failure``
    why the map was not analysed, empty when it was)."""
    with netCDF4.Dataset(path, "r") as nc:
        nc.set_auto_mask(False)
        i = controller_row(nc, path, controller)
        out = {"fixed_point": np.array(nc.variables["fixed_point"][i, :], float),
               "map_defect": float(nc.variables["map_defect"][i])}
        nc_conv = nc.variables.get("newton_converged")
        out["newton_converged"] = int(nc_conv[i]) if nc_conv is not None else -1
        stop = nc.variables.get("newton_stop")
        out["newton_stop"] = str(np.atleast_1d(stop[...])[i]) if stop is not None else ""
        for key in ("t_switch", "t_motor", "motor_torque"):
            out[key] = float(nc.variables[key][i]) if key in nc.variables else math.nan
        failure = nc.variables.get("failure")
        out["failure"] = str(np.atleast_1d(failure[...])[i]) if failure is not None else ""
    return out


def read_floquet_multipliers(path: Path, controller: str) -> np.ndarray:
    """The variational multipliers of one controller of a floquet dataset (complex)."""
    with netCDF4.Dataset(path, "r") as nc:
        nc.set_auto_mask(False)
        i = controller_row(nc, path, controller)
        re = np.array(nc.variables["multipliers_real"][i, :])
        im = np.array(nc.variables["multipliers_imag"][i, :])
    return re + 1j * im


def robot_attr(study_robot: Robot, robot: Robot, source: str) -> dict:
    """The ``robot`` attribute of runs on ``robot``: the study's if it is the study's to
    round-off (a design that kept it), else its own, named after the step it came from."""
    links = [(lk.mass, lk.length, lk.com, lk.inertia)
             for lk in (robot.link1, robot.link2, study_robot.link1, study_robot.link2)]
    # a design's links are rebuilt from ratios: equal to the base's to round-off
    if np.allclose(links[:2], links[2:], rtol=1e-12, atol=0.0):
        return study_robot.to_dict()
    return dict(robot.to_dict(), name=f"{source} design (from {study_robot.name})")


__all__ = ["GaitStart", "MAX_MAP_DEFECT", "StartRequest", "read_start", "run_problems", "METHOD_NAMES", "best_grid_points", "design_start",
           "floquet_start", "gait_line", "grid_minima", "motor_torque_of", "no_start_attrs",
           "option_problems", "pick_solution", "read_floquet_multipliers",
           "read_floquet_point", "read_refined", "read_shoot", "refine_start", "robot_attr",
           "shoot_start", "usable"]


def read_start(reader, dep, ctx, options: dict):
    """What ``dep``'s kind hands on to ``ctx``'s step: ``reader`` (one of the readers above)
    on its dataset with the step's ``options`` (:class:`StartRequest` fields)."""
    return reader(dep.path, dep.step.name, ctx, StartRequest(**options))
