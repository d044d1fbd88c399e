"""Which kind of horizontal gait a start gives: does the swap come on the first swing?

The 2009 study's gait swaps on its first upswing (B reaches A's height before link 1 ever
passes back through the vertical). A start with too little energy for that can still swap,
after swinging to and fro several times, at a much later time; its error can be small too,
but it is another gait, and replayed open loop it behaves differently. Counting how often link
1 passes the vertical before the swap tells the two apart.
"""
from __future__ import annotations

from ..controllers import (
    Integrator, Observer, PhaseSequence, SequenceGait, horizontal_gait,
)
from ..kernel import layout as L
from ..robot import SEED2009_TORQUE
from ..simulation import RobotLike, run_controller
from .sections import cycle_section_state


def vertical_passes_before_swap(dtheta1: float, dtheta2: float, *,
                                robot: RobotLike = "seed2009",
                                torque: float = SEED2009_TORQUE, tick: float = 0.0,
                                integrator: Integrator = Integrator(),
                                gait: SequenceGait | None = None) -> int:
    """How many times link 1 passes the vertical before the gait's swap, started on its
    section with rates ``(dtheta1, dtheta2)`` [rad s-1]; -1 when it never swaps.

    ``gait``: a gait whose first segment ends in its swap (default the horizontal gait,
    :func:`~monkeystudy.controllers.horizontal_gait` of ``torque`` [N m] and ``tick`` [s]).
    The same program and integrator as the gait's evaluation, with an observer on
    ``theta1 = 0`` during the first segment (observers never change a run's steps).
    """
    gait = horizontal_gait(torque, tick) if gait is None else gait
    vertical = Observer("coord", "theta1", 0.0, "either", segment=0)
    ctrl = PhaseSequence(gait.all_segments(), (vertical,), gait.tick, gait.tick_phase,
                         gait.rise)
    res = run_controller(ctrl, cycle_section_state(gait, [gait.theta2, dtheta1, dtheta2]),
                         robot=robot, integrator=integrator, cycles=1, log_capacity=4096)
    log = res.log
    swaps = log[(log[:, L.L_KIND] == L.LOG_SEGMENT) & (log[:, L.L_ID] == 0)]
    if swaps.shape[0] == 0:
        return -1
    t_swap = swaps[0, L.L_T]
    passes = log[(log[:, L.L_KIND] == L.LOG_OBSERVER) & (log[:, L.L_T] < t_swap)]
    return int(passes.shape[0])


def gait_kind_text(passes: int) -> str:
    """The gait's kind in words, from :func:`vertical_passes_before_swap`."""
    if passes < 0:
        return "never swaps"
    if passes == 0:
        return "swaps on the first swing"
    return (f"swaps after link 1 passed the vertical {passes} time{'s' if passes > 1 else ''}"
            " (not a first-swing gait)")

