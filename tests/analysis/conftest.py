"""Fixtures of the analysis tests."""
import pytest

from sequencegaits import solve_flight_point, solve_two_step_point


@pytest.fixture(scope="session")
def two_step_point():
    """The two-step gait's fixed point at theta2 = 0 for seed2009 (from the study's refine),
    polished by Newton with the variational Jacobian."""
    return solve_two_step_point()


@pytest.fixture(scope="session")
def flight_point():
    """The flight gait's fixed point for seed2009 (studies/flight_gait.yaml), polished by
    Newton with the variational Jacobian."""
    return solve_flight_point()
