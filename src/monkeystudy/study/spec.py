"""A study resolved into plain values: the gait every task evaluates, and how datasets name it.

The robot enters once, from the validated study model (:func:`gait_spec`); tasks receive it
as a :class:`~monkeystudy.Robot` inside a :class:`GaitSpec` (picklable frozen dataclasses,
nothing rebuilt on the workers), and datasets record it as ``Robot.to_dict()`` JSON.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..controllers import Integrator, SequenceGait, horizontal_gait
from ..robot import Robot


@dataclass(frozen=True)
class GaitSpec:
    """What every task needs to evaluate the study's gait.

    Attributes
    ----------
    robot : Robot
    integrator : Integrator
    torque : float
        Motor torque of the horizontal gait [N m]; NaN for a sequence gait (its segments
        carry their own).
    tick : float
        Controller tick [s]; 0 = exact event timing.
    sequence : SequenceGait
        The gait as a phase sequence: the study's sequence gait, or the horizontal gait's
        (:func:`~monkeystudy.controllers.horizontal_gait` of ``torque`` and ``tick``, filled
        in when not given).
    swap_motor_times : bool
        Datasets name a cycle's times as the 2009 study did (``t_switch``, ``t_motor``,
        ``t_end``), else per segment (:class:`~monkeystudy.study.models.Conventions`; default:
        the 2009 names when no sequence is given).
    torque_frame : str
        The frame the study wrote the gait's torques in (``attached_end`` or ``motor``,
        :data:`~monkeystudy.controllers.TORQUE_FRAMES`); ``sequence`` carries them in the
        kernel's frame either way. Datasets that record torques over time state them in it.
    has_gait : bool
        False: a study without a gait (its steps run none, :attr:`~monkeystudy.study.steps.
        base.StepKind.runs_gait`): ``torque`` and ``tick`` NaN, ``sequence`` None; its tasks
        use the robot (and their own integrator) alone.
    """

    robot: Robot
    integrator: Integrator
    torque: float
    tick: float
    sequence: SequenceGait | None = None
    swap_motor_times: bool | None = None
    torque_frame: str = "attached_end"
    has_gait: bool = True

    def __post_init__(self):
        if not self.has_gait:
            if self.sequence is not None:
                raise ValueError("a GaitSpec without a gait has no sequence")
            object.__setattr__(self, "swap_motor_times", False)
            return
        if self.swap_motor_times is None:
            object.__setattr__(self, "swap_motor_times", self.sequence is None)
        if self.sequence is None:
            object.__setattr__(self, "sequence", horizontal_gait(self.torque, self.tick))

    @property
    def n_cycle_segments(self) -> int:
        """Segments of the gait's cycle, the section included, as datasets record them per
        segment (0: named the 2009 way)."""
        return 0 if self.swap_motor_times or self.sequence is None else \
            len(self.sequence.segments) + 1


def gait_spec(study) -> GaitSpec:
    """The :class:`GaitSpec` of a validated :class:`~monkeystudy.study.schema.Study` (one
    without a gait: ``has_gait`` False)."""
    g = study.gait
    if g is None:
        return GaitSpec(study.to_robot(), study.integrator.to_integrator(), math.nan, math.nan,
                        has_gait=False)
    return GaitSpec(study.to_robot(), study.integrator.to_integrator(), float(g.motor_torque),
                    float(g.tick), g.gait(), g.conventions.swap_motor_times,
                    getattr(g, "torque_frame", "attached_end"))


def integrator_fields(integrator: Integrator) -> dict:
    """The integrator settings a study can set, as datasets and step keys record them."""
    return {"method": integrator.method, "rtol": integrator.rtol, "atol": integrator.atol,
            "max_time": integrator.max_time, "controller": integrator.controller}


def gait_json(study) -> dict | None:
    """The study's gait as datasets and step keys record it (None: the study has none)."""
    return study.gait.model_dump(mode="json") if study.gait is not None else None


def mirror_problem(robot: Robot) -> str | None:
    """Why ``robot`` cannot have one-cycle return maps (``None`` if it can).

    The frame flips to the other end at every swap, so a one-cycle return map compares like
    with like only when the links are mirror images (:mod:`monkeystudy.analysis.sections`).
    """
    if robot.is_mirror_image:
        return None
    return ("needs mirror-image links (same mass, length, inertia and friction; link 2's "
            "com = its length - link 1's com): the frame flips at every swap, so a one-cycle "
            "return map is defined only for them")

