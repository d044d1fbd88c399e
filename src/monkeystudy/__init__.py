"""monkeystudy: batch gait studies of the MonkeyBot brachiating robot.

The public simulation API; study drivers live in :mod:`monkeystudy.study`, figures in
:mod:`monkeystudy.plotting`.
"""
__version__ = "0.1.0"

from .controllers import (  # noqa: E402
    HorizontalSearch, Integrator, Observer, OpenLoop, PhaseSequence, Segment, SequenceGait,
)
from .robot import Friction, Link, Robot, SEED2009_TORQUE  # noqa: E402
from .simulate import (  # noqa: E402
    GaitResult, RunResult, Status, evaluate_cycle_gaits, evaluate_gaits, evaluate_horizontal_gait,
    initial_state, run_controller, simulate,
)

__all__ = [
    "Friction", "GaitResult", "HorizontalSearch", "Integrator", "Link", "Observer", "OpenLoop",
    "PhaseSequence", "Robot", "RunResult", "SEED2009_TORQUE", "Segment", "SequenceGait", "Status",
    "evaluate_cycle_gaits", "evaluate_gaits", "evaluate_horizontal_gait", "initial_state", "run_controller", "simulate",
]
