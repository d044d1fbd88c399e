"""Sequence gaits and their fixed point shared by the analysis tests (continuation, replay,
rise, walk)."""
import dataclasses
from functools import partial

import numpy as np

from monkeystudy.analysis import cycle_return_map, solve_fixed_point
from monkeystudy.controllers import Integrator, Segment, SequenceGait
from monkeystudy.analysis.variational import sequence_variational_jacobian

TORQUE = 0.6354
INTEG = Integrator(method="dop853", rtol=1e-12, atol=1e-13)

#: studies/descending_design.yaml's gait (motor frame): a step 0.1 m down, its catch at the
#: route's planned height, one swap
DESCENDING = {
    "kind": "sequence", "torque_frame": "motor", "rise": -0.1,
    "section": {"theta1": 0.0, "direction": "either", "theta2": -1.241},
    "segments": [
        {"until": "time", "value": 7.519090701371105e-08},
        {"until": "free_end_y", "value": -0.1, "direction": "rising", "torque": -0.2118,
         "clock": "reset"},
        {"until": "time", "value": 0.2, "magnets": "swap", "torque": 0.2118}]}
#: its fixed point (theta2 [rad], dtheta1, dtheta2 [rad s-1]), by Newton at rtol 1e-12
Z_DESCENDING = np.array([-1.2410195771999732, 3.141805394182587, 7.739977215255691])


def descending(**changes) -> SequenceGait:
    """:data:`DESCENDING` as the kernel runs it (torques in its frame), with ``changes``."""
    from monkeystudy.study.models import SequenceGaitSpec
    return dataclasses.replace(SequenceGaitSpec.model_validate(DESCENDING).gait(), **changes)


def two_step(torque: float = TORQUE) -> SequenceGait:
    """studies/two_step.yaml: the state-based horizontal gait as a two-swap cycle (it ends on
    A, so its return map exists for any robot)."""
    return SequenceGait([
        Segment("free_end_height", 0.0, direction="rising", latch_energy=True),
        Segment("energy_restored", 0.0, magnets="swap", torque=torque),
        Segment("coord", 0.0, coord="theta1", direction="either"),
        Segment("free_end_height", 0.0, direction="rising", latch_energy=True),
        Segment("energy_restored", 0.0, magnets="swap", torque=torque)], theta2=0.0)


def two_swing() -> SequenceGait:
    """studies/two_swing.yaml: a full oscillation before the swap (ends on B)."""
    return SequenceGait([
        Segment("coord", 0.0, coord="theta1", direction="falling", latch_energy=True),
        Segment("coord", 0.0, coord="theta1", direction="rising"),
        Segment("free_end_height", 0.0, direction="rising"),
        Segment("energy_restored", 0.0, magnets="swap", torque=TORQUE)], theta2=0.0)


def flight() -> SequenceGait:
    """studies/flight_gait.yaml: swing up, release A at theta1 = 0.6 rad, fly until B rises to
    A's starting height, catch with B and restore the energy; the cycle ends hanging from B
    (mirror-image links), and names its ends (a release of every magnet, a catch with B)."""
    return SequenceGait([
        Segment("coord", 0.6, coord="theta1", direction="rising", latch_energy=True),
        Segment("free_end_y", 0.0, direction="rising", magnets="none"),
        Segment("energy_restored", 0.0, magnets="B", torque=TORQUE)],
        section_theta1=0.0, section_direction="either", theta2=0.3)


def solve_flight_point() -> np.ndarray:
    """The flight gait's fixed point for seed2009 (docs/findings.md section 4: (0.3, 1.8923,
    9.9562)), polished by Newton with the variational Jacobian."""
    g = flight()
    fmap = partial(cycle_return_map, gait=g, robot="seed2009", integrator=INTEG)
    fp = solve_fixed_point(fmap, np.array([0.3, 1.8923, 9.9562]), jacobian=lambda q:
                           sequence_variational_jacobian(g, q, robot="seed2009",
                                                         integrator=INTEG))
    if not fp.converged:
        raise RuntimeError(f"flight fixed point did not converge: {fp}")
    return fp.z


def solve_two_step_point() -> np.ndarray:
    """The two-step gait's fixed point at theta2 = 0 for seed2009 (from the study's refine)."""
    g = two_step()
    fmap = partial(cycle_return_map, gait=g, robot="seed2009", integrator=INTEG)
    fp = solve_fixed_point(fmap, np.array([0.0, 0.74231351, 11.16262254]), jacobian=lambda q:
                           sequence_variational_jacobian(g, q, robot="seed2009",
                                                         integrator=INTEG))
    if not fp.converged:
        raise RuntimeError(f"two-step fixed point did not converge: {fp}")
    return fp.z
