"""The full return map, the attached end's height included (analysis.cycle_full_map,
sequence_variational_jacobian(height=True)): ``w = (y, theta2, dtheta1, dtheta2)``.

Physics: the equations of motion, the impacts and every guard that senses only joint angles,
rates, relative heights and time are invariant under ``y -> y + c``, so the full map commutes
with the translation and its y-column is exactly ``e_y``: a multiplier 1, the height neutral.
A catch at a world height (``free_end_y`` at the start's height) sets the next height whatever
the start, so the y-row vanishes: the height's multiplier is 0 and the full map's spectral
radius is the reduced map's.
"""
import numpy as np
import pytest

from monkeystudy.analysis import TIGHT, cycle_full_map, cycle_return_map, jacobian_fd
from monkeystudy.analysis.variational import sequence_variational_jacobian
from monkeystudy.controllers import Segment, SequenceGait, horizontal_gait
from monkeystudy.study.models import SequenceGaitSpec

from test_motor_frame import DESIGN_B, Z_B

E_Y = np.array([1.0, 0.0, 0.0, 0.0])
#: near the state-based controller's attracting gait (tests/analysis/test_analysis.py)
Z_SEARCH = np.array([0.02475681, -1.08686037, 16.0167845])


def full_fd(gait, w, step=1e-5):
    return jacobian_fd(lambda q: cycle_full_map(q, gait), w, step)


def moduli(J):
    return np.sort(np.abs(np.linalg.eigvals(J)))[::-1]


def design_b(catch: str = "free_end_y") -> SequenceGait:
    spec = dict(DESIGN_B, segments=[dict(s) for s in DESIGN_B["segments"]])
    spec["segments"][1]["until"] = catch
    return SequenceGaitSpec.model_validate(spec).gait()


@pytest.mark.parametrize("name", ["search", "design_b_relative_catch"])
def test_a_gait_sensing_no_world_height_has_the_height_neutral(name):
    """The state-based 2009 controller (catch when B reaches A's height, motor until the
    energy is restored) and design B with its catch at B reaching A's height (a relative
    height): the y-column is e_y exactly (variational) and to the finite differences' accuracy;
    the multipliers are 1 and the reduced map's."""
    gait, z = ((horizontal_gait(0.6354), Z_SEARCH) if name == "search"
               else (design_b("free_end_height"), Z_B))
    w = np.concatenate([[0.0], z])
    J = sequence_variational_jacobian(gait, w, height=True)
    np.testing.assert_array_equal(J[:, 0], E_Y)
    Jfd = full_fd(gait, w)
    np.testing.assert_allclose(Jfd[:, 0], E_Y, rtol=0, atol=1e-9)
    # the rest of the full map is the reduced map (same rows and columns)
    Jred = sequence_variational_jacobian(gait, z)
    np.testing.assert_allclose(J[1:, 1:], Jred, rtol=1e-10, atol=1e-12)
    lam = np.linalg.eigvals(J)
    assert np.min(np.abs(lam - 1.0)) < 1e-12
    np.testing.assert_allclose(moduli(J), np.sort(np.r_[1.0, moduli(Jred)])[::-1],
                               rtol=1e-10)
    # the symmetry itself: translating the start moves the next state by the same height
    w0, _ = cycle_full_map(w, gait)
    for c in (1.0, -3.7):
        wc, _ = cycle_full_map(w + c * E_Y, gait)
        assert wc[0] - c == pytest.approx(w0[0], abs=1e-12)
        np.testing.assert_allclose(wc[1:], w0[1:], rtol=0, atol=1e-12)


def test_design_b_catch_at_the_start_height_makes_the_height_multiplier_vanish():
    """Design B catches B when it rises through the start's world height: the next height is
    that height whatever the start (y-row 0), so the height's multiplier is 0 and rho of the
    full map equals the reduced map's (0.3041373041 by variational equations, 0.30413727 by
    finite differences); the two Jacobians agree to 1e-6."""
    gait = design_b()
    zn, status = cycle_return_map(Z_B, gait, integrator=TIGHT)
    assert status == 0 and np.max(np.abs(zn - Z_B)) < 1e-12        # the fixed point
    w = np.concatenate([[0.0], Z_B])
    J = sequence_variational_jacobian(gait, w, height=True)
    Jfd = full_fd(gait, w)
    assert np.max(np.abs(J[0])) < 1e-12                             # y' does not move
    assert np.max(np.abs(Jfd[0])) < 1e-9
    assert np.max(np.abs(J[1:, 0])) > 1.0                           # but y moves the rest
    assert np.max(np.abs(J - Jfd)) / np.max(np.abs(J)) < 1e-6        # measured 7e-11
    Jred = sequence_variational_jacobian(gait, Z_B)
    rho_full, rho_red = moduli(J)[0], moduli(Jred)[0]
    assert rho_full == pytest.approx(rho_red, rel=1e-12)
    assert rho_full == pytest.approx(0.3041373041, abs=1e-9)
    assert moduli(Jfd)[0] == pytest.approx(rho_full, abs=1e-6)      # measured 3.6e-8
    assert moduli(J)[-1] < 1e-12                                    # the height's multiplier


def test_full_map_refuses_a_running_clock():
    clocked = SequenceGait([Segment("time", value=0.4, magnets="swap")], period=0.9)
    with pytest.raises(ValueError, match="running clock"):
        cycle_full_map([0.0, 0.0, 0.0, 1.0, 1.0], clocked)
    with pytest.raises(ValueError, match="running clock"):
        sequence_variational_jacobian(clocked, [0.0, 0.0, 0.0, 1.0, 1.0], height=True)
