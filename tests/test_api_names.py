"""The simulation API's names for what the kernel exchanges as plain numbers: status codes,
phases, state indices, the fields of a run's result and its energy. The study drivers and the
figures read results only through these (they never import the kernel), so each must stay
exactly the kernel's number."""
import numpy as np
import pytest

from monkeystudy import OpenLoop, Robot, evaluate_horizontal_gait
from monkeystudy.kernel import layout as L
from monkeystudy.kernel.dynamics import kinetic_energy as kernel_kinetic_energy
from monkeystudy.simulation import (
    STATUS_NAMES, Phase, StateIndex, Status, initial_state, kinetic_energy, run_controller,
    status_name,
)


def test_status_values_and_names_are_the_kernels():
    """Datasets write the kernel's codes with these names as flag_meanings: the codes run
    0..n-1 in the kernel's order, so ``STATUS_NAMES[code]`` names a code."""
    assert [int(s) for s in Status] == list(range(len(L.STATUS_NAMES)))
    assert STATUS_NAMES == L.STATUS_NAMES
    for code, name in enumerate(L.STATUS_NAMES):
        assert status_name(code) == status_name(np.int8(code)) == name
        assert Status(code).name.lower() == name
    assert Status.OK == L.ST_OK and Status.UNREACHABLE == L.ST_UNREACHABLE
    assert Status.NO_RETURN_TO_VERTICAL == L.ST_NO_RETURN and Status.FELL == L.ST_FELL
    with pytest.raises(ValueError):
        status_name(len(STATUS_NAMES))


def test_phases_and_state_indices_are_the_kernels():
    assert (Phase.SWING, Phase.FLIGHT, Phase.FIXED) == (L.PHASE_SWING, L.PHASE_FLIGHT,
                                                         L.PHASE_FIXED)
    assert list(StateIndex) == [L.X, L.Y, L.TH1, L.TH2, L.DX, L.DY, L.DTH1, L.DTH2]
    assert [s.name.lower() for s in StateIndex] == [
        "x", "y", "theta1", "theta2", "x_dot", "y_dot", "theta1_dot", "theta2_dot"]


def test_a_run_results_named_fields_read_its_arrays():
    g = evaluate_horizontal_gait(0.902, 10.935, tick=0.001)
    res = run_controller(OpenLoop(g.t_switch, g.t_motor, 0.6354, tick=0.001),
                         initial_state(0.902, 10.935), cycles=2, sample_dt=0.01)
    assert (res.steps, res.nfev, res.rejected, res.cycles) == tuple(
        int(res.counts[k]) for k in (L.K_STEPS, L.K_NFEV, L.K_REJECTED, L.K_CYCLES))
    assert res.cycles == 2 and res.steps > 0
    for name, col in (("sample_phase", L.M_PHASE), ("sample_flipped", L.M_FLIPPED),
                      ("sample_torque", L.M_TORQUE), ("sample_segment", L.M_SEGMENT)):
        np.testing.assert_array_equal(getattr(res, name), res.sample_mode[:, col])
    assert set(np.unique(res.sample_flipped)) == {0.0, 1.0}


def test_kinetic_energy_is_the_kernels():
    robot = Robot.preset("seed2009")
    s = np.array([0.0, 0.0, 0.3, -0.4, 0.0, 0.0, 1.2, 10.5])
    for flipped in (False, True):
        want = kernel_kinetic_energy(robot.params()[int(flipped)], *s[2:])
        assert kinetic_energy(robot, s, flipped=flipped) == want
    assert kinetic_energy("seed2009", s) == kinetic_energy(robot, s) > 0
