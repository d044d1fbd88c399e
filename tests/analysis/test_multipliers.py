"""Fixed points by Newton (``solve_fixed_point``): its stopping test against the map's own
error level, on a map with known noise and on a gait's return map at the default
integrator tolerance."""
from __future__ import annotations

from functools import partial

import numpy as np
import pytest

from monkeystudy.analysis import cycle_map_error, cycle_return_map, solve_fixed_point
from monkeystudy.analysis.variational import sequence_variational_jacobian
from monkeystudy.controllers import Integrator, Segment, SequenceGait
from monkeystudy.simulation import Status

#: a linear map's fixed point and Jacobian (multipliers 1.9, 0.62, 0.28: no neutral one)
Z_STAR = np.array([1.0, 4.4, 0.3])
A = np.array([[0.3, 0.1, 0.0], [0.0, 1.8, 0.2], [0.1, 0.0, 0.7]])


def noisy_map(z, noise: float):
    """``z* + A (z - z*)`` plus a deterministic perturbation of size ``noise`` that changes
    on the scale of round-off in ``z`` (as an integrator's error does)."""
    z = np.asarray(z, float)
    wiggle = np.sin(1e13 * z * np.array([1.0, 1.7, 2.3]) + np.array([0.0, 1.0, 2.0]))
    return Z_STAR + A @ (z - Z_STAR) + noise * wiggle, Status.OK


def test_newton_stops_at_the_maps_error_level():
    fmap = partial(noisy_map, noise=1e-10)
    z0 = Z_STAR + np.array([1e-3, -2e-3, 1e-3])
    fp = solve_fixed_point(fmap, z0, jacobian=lambda q: A, map_error=1e-9)
    assert fp.converged, fp.message
    assert "map's error level" in fp.message
    # the residual cannot go below the noise, and the point is as good as the noise allows
    assert 1e-12 < fp.defect <= 1e-9
    assert np.abs(fp.z - Z_STAR).max() < 1e-8
    assert fp.map_error == 1e-9


def test_newton_without_an_error_level_says_it_did_not_converge():
    fmap = partial(noisy_map, noise=1e-10)
    fp = solve_fixed_point(fmap, Z_STAR + 1e-3, jacobian=lambda q: A)
    assert not fp.converged
    assert fp.message.startswith("not converged")


def test_a_residual_above_the_maps_error_is_no_fixed_point():
    # a neutral direction with a constant drift along it: no fixed point, and the
    # least-squares step (the neutral singular value dropped) is 0
    c = np.array([0.0, 0.0, 1e-6])
    M = np.diag([0.5, 0.5, 1.0])
    fp = solve_fixed_point(lambda z: (M @ (np.asarray(z) - Z_STAR) + Z_STAR + c, Status.OK),
                           Z_STAR, jacobian=lambda q: M, map_error=1e-9)
    assert not fp.converged and fp.message.startswith("not converged"), fp.message
    assert fp.defect == pytest.approx(1e-6)


#: studies/climbing_gait.yaml's gait: a 0.05 m climb per cycle
CLIMBING = SequenceGait([
    Segment("free_end_height", 0.05, direction="rising", latch_energy=True),
    Segment("energy_restored", 0.981, magnets="swap", torque=0.6354)], theta2=1.0)
#: its refined start (Nelder-Mead at rtol 1e-10, gait error 1.4e-22)
CLIMBING_START = np.array([1.0, 4.447805743536215, 0.2754242721236736])


def polish(integrator: Integrator, map_error: float):
    fmap = partial(cycle_return_map, gait=CLIMBING, robot="seed2009", integrator=integrator)
    return solve_fixed_point(fmap, CLIMBING_START, map_error=map_error, jacobian=lambda q:
                             sequence_variational_jacobian(CLIMBING, q, robot="seed2009",
                                                           integrator=integrator))


def test_a_gait_polished_at_the_default_tolerance_converges_to_the_exact_fixed_point():
    default = Integrator()                       # rtol 1e-10, atol 1e-12
    level = cycle_map_error(CLIMBING_START, CLIMBING, integrator=default)
    # the map's error at rtol 1e-10 is ~3e-9: its residual stalls near 1e-11, far inside
    assert 1e-10 < level < 1e-7
    fp = polish(default, level)
    assert fp.converged, fp.message
    assert fp.defect <= level
    # the same fixed point at rtol 1e-13 (its residual 1e-12 in reach): they agree to about
    # the map's error
    tight = Integrator(rtol=1e-13, atol=1e-15)
    exact = polish(tight, cycle_map_error(CLIMBING_START, CLIMBING, integrator=tight))
    assert exact.converged and exact.defect < 1e-11, exact.message
    assert np.linalg.norm(fp.z - exact.z) < 10 * level
    assert np.linalg.norm(fp.z - exact.z) > 0.0


def test_the_map_error_falls_with_the_tolerance():
    levels = [cycle_map_error(CLIMBING_START, CLIMBING,
                              integrator=Integrator(rtol=r, atol=r / 100))
              for r in (1e-8, 1e-10, 1e-12)]
    assert levels[0] > 10 * levels[1] > 100 * levels[2] > 0.0
