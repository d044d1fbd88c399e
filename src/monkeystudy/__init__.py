"""monkeystudy: batch gait studies of the MonkeyBot brachiating robot.

The public simulation API; study drivers live in :mod:`monkeystudy.study`, figures in
:mod:`monkeystudy.plotting`.

The names below are imported on first use (PEP 562): ``import monkeystudy`` alone does not
load numba and the kernels, so the command line's thin paths (``--help``, a run handed to
``monkeystudy serve``) start in a fraction of the time.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

from ._lazy import lazy_exports

__version__ = "0.1.0"

_EXPORTS = {
    "controllers": ("HorizontalSearch", "Integrator", "Observer", "OpenLoop", "PhaseSequence",
                    "Segment", "SequenceGait", "horizontal_gait"),
    "robot": ("Friction", "Link", "Motor", "Robot", "Rotor", "SEED2009_TORQUE"),
    "simulation": ("GaitResult", "RunResult", "Status", "evaluate_cycle_gaits", "evaluate_gaits",
                   "evaluate_horizontal_gait", "initial_state", "run_controller", "simulate"),
}
__getattr__, __dir__, __all__ = lazy_exports(__name__, globals(), _EXPORTS)

if TYPE_CHECKING:  # static analysers and IDEs see the eager imports
    from .controllers import (  # noqa: F401
        HorizontalSearch, Integrator, Observer, OpenLoop, PhaseSequence, Segment, SequenceGait,
        horizontal_gait,
    )
    from .robot import SEED2009_TORQUE, Friction, Link, Motor, Robot, Rotor  # noqa: F401
    from .simulation import (  # noqa: F401
        GaitResult, RunResult, Status, evaluate_cycle_gaits, evaluate_gaits,
        evaluate_horizontal_gait, initial_state, run_controller, simulate,
    )
