"""The gait a step starts from, read from its ``from:`` step's dataset as plain values (what
the survival and design steps run): the section state, the open-loop schedule or the
sequence gait's segment times, and where it came from."""
from __future__ import annotations

import math

import numpy as np

from ...analysis.replay import cycle_times
from ...kernel import layout as L
from ...kernel.layout import STATUS_NAMES
from ..errors import RunFailed
from .base import StepContext
from .floquet import read_floquet_point, sequence_attrs, sequence_start
from .refine import read_refined
from .shoot import replay_torque, shoot_gait

#: a floquet step's point is run when the return map moves it less than this [1]
MAX_MAP_DEFECT = 1e-8


def step_gait(ctx: StepContext, max_map_defect: float = MAX_MAP_DEFECT) -> dict:
    """The gait a step runs (its ``from:``) as plain values: ``replay``, the section state ``z``, and
    what its controller needs (``t_switch``, ``t_motor``, ``t_end``, ``torque`` for an
    open-loop replay of the horizontal gait; ``t_segment`` for a sequence gait's), with the
    attributes naming where it came from (``source``)."""
    st = ctx.step
    src = ctx.deps[st.from_]
    if ctx.gait_kind == "sequence":
        g = sequence_start(ctx, max_map_defect)
        replay = st.replay or "gait"
        out = {"replay": replay, "z": [float(v) for v in g["z"]],
               "source": sequence_attrs(g, replay)}
        if replay == "open_loop":
            out["t_segment"] = [float(t) for t in cycle_times(
                ctx.spec.sequence, g["z"], robot=ctx.spec.robot,
                integrator=ctx.spec.integrator)]
        return out
    replay = st.replay or "open_loop"
    if src.kind == "floquet":
        controller = "search" if replay == "gait" else "open_loop"
        fp = read_floquet_point(src.path, controller)
        z = fp["fixed_point"]
        # a neutral multiplier (the search controller's family) leaves Newton short of its
        # tolerance on a point that is a fixed point to the map's accuracy: judge the defect
        if not (np.all(np.isfinite(z)) and fp["map_defect"] <= max_map_defect):
            raise RunFailed(f"{ctx.name}: floquet step {st.from_!r} has no {controller} fixed "
                            f"point to run (map defect {fp['map_defect']:.3g})")
        out = {"replay": replay, "z": [float(v) for v in z],
               "t_switch": fp["t_switch"], "t_motor": fp["t_motor"],
               "torque": fp["motor_torque"], "t_end": math.nan,
               "source": {"floquet_step": st.from_, "floquet_controller": controller,
                          "map_defect": fp["map_defect"],
                          "newton_converged": fp["newton_converged"]}}
        if replay == "gait":
            out["torque"] = float(ctx.spec.torque)
        return out
    if src.kind == "shoot":
        g = shoot_gait(ctx, st.from_, st.solution)
        source = {"shoot_step": st.from_, "solution": int(g["index"]),
                  "gait_error": float(g["error"])}
    else:
        g, idx = read_refined(src.path, st.start_index)
        if g["status"] != L.ST_OK:
            raise RunFailed(f"{ctx.name}: refine step {st.from_!r} found no gait to run "
                            f"(status {STATUS_NAMES[g['status']]})")
        source = {"refine_step": st.from_, "refine_start": idx, "gait_error": g["error"]}
    return {"replay": replay, "z": [0.0, float(g["dtheta1"]), float(g["dtheta2"])],
            "t_switch": float(g["t_switch"]), "t_motor": float(g["t_motor"]),
            "t_end": float(g.get("t_end", math.nan)), "torque": replay_torque(ctx.spec, g),
            "source": source}
