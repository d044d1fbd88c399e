"""Which kind of horizontal gait a start gives: does the swap come on the first swing?

The 2009 study's gait swaps on its first upswing (B reaches A's height before link 1 ever
passes back through the vertical). A start with too little energy for that can still swap,
after swinging to and fro several times, at a much later time; its error can be small too,
but it is another gait, and replayed open loop it behaves differently. Counting how often link
1 passes the vertical before the swap tells the two apart.
"""
from __future__ import annotations

from ..controllers import HorizontalSearch, Integrator, Observer, PhaseSequence
from ..kernel import layout as L
from ..robot import SEED2009_TORQUE
from ..simulate import RobotLike, initial_state, run_controller

#: link 1 through the vertical, watched before the swap only (program row 0)
VERTICAL_BEFORE_SWAP = Observer("coord", "theta1", 0.0, "either", segment=0)


def vertical_passes_before_swap(dtheta1: float, dtheta2: float, *,
                                robot: RobotLike = "seed2009",
                                torque: float = SEED2009_TORQUE, tick: float = 0.0,
                                integrator: Integrator = Integrator()) -> int:
    """How many times link 1 passes the vertical before the horizontal gait's swap, started
    hanging from A with rates ``(dtheta1, dtheta2)`` [rad s-1]; -1 when it never swaps.

    The same controller and integrator as the gait evaluation, with an observer on
    ``theta1 = 0`` during the swing to the swap (observers never change a run's steps).
    """
    search = HorizontalSearch(torque, tick=tick)
    ctrl = PhaseSequence(search.segments(), (VERTICAL_BEFORE_SWAP,), tick)
    res = run_controller(ctrl, initial_state(dtheta1, dtheta2), robot=robot,
                         integrator=integrator, log_capacity=4096)
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

