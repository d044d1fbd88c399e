"""A sequence gait's ``rise`` [m per cycle]: the world heights its ``free_end_y`` guards name
move by ``rise`` each cycle, a staircase fixed in the world (docs/model.md sections 6 and 7).

Physics: in cycle k the catch is at the planned height ``value + k * rise``, the end the
robot hangs from at ``k * rise``, so each cycle is the first translated by ``k * rise``
and repeats it; a catch at a world height sets the next height whatever the start, so the
full map's height (measured from the staircase) has multiplier 0, not the neutral 1 of a
catch relative to the attached end (``free_end_height``).
"""
import dataclasses

import numpy as np
import pytest

from monkeystudy.analysis import cycle_full_map, cycle_section_state, jacobian_fd
from monkeystudy.analysis.replay import sequence_cycles
from monkeystudy.analysis.survival import Noise, survival_runs
from monkeystudy.analysis.variational import sequence_variational_jacobian
from monkeystudy.controllers import Integrator, Segment, SequenceGait
from monkeystudy.kernel import layout as L
from monkeystudy.study.models import SequenceGaitSpec

from sequencegaits import DESCENDING, Z_DESCENDING, descending

RISE = -0.1                                     # m per cycle: a step down
INTEG = Integrator(rtol=1e-12, atol=1e-13)


def test_the_descending_gait_catches_on_the_staircase_for_50_cycles():
    """50 cycles from the fixed point: cycle k's catch (the end the robot hangs from at its
    section) is at -0.1 (k + 1) m to the integrator's accuracy, and every cycle returns to
    the fixed point. The runs go 5 m down with max_drop 1 m: a fall is measured from the
    planned height."""
    c = sequence_cycles(descending(), Z_DESCENDING, cycles=50, integrator=INTEG, max_drop=1.0)
    assert int(c.status) == 0 and len(c.pivot_height) == 50
    k = np.arange(1, 51)
    np.testing.assert_allclose(c.pivot_height, RISE * k, rtol=0, atol=1e-10)
    assert np.max(c.error) < 1e-20


def test_without_the_rise_the_same_guard_is_one_fixed_world_height():
    """The same program without a rise catches at -0.1 m in every cycle: a different gait
    (its later catches are level with the end the robot hangs from)."""
    c = sequence_cycles(descending(rise=0.0), Z_DESCENDING, cycles=3, integrator=INTEG,
                        max_drop=1.0)
    np.testing.assert_allclose(c.pivot_height[:2], [RISE, RISE], rtol=0, atol=1e-10)
    assert np.max(c.error) > 1e-6


def test_the_full_map_measures_the_height_from_the_staircase():
    """The full map at (0, z*): a fixed point (the cycle ends one rise down, at the next
    planned height); its height row vanishes (the catch sets the next height whatever the
    start), so the height's multiplier is 0, the full map's spectral radius is the section
    map's (< 1), and variational equations agree with finite differences to 1e-6."""
    gait = descending()
    w = np.r_[0.0, Z_DESCENDING]
    wn, status = cycle_full_map(w, gait, integrator=INTEG)
    assert status == 0
    np.testing.assert_allclose(wn, w, rtol=0, atol=1e-11)
    J = sequence_variational_jacobian(gait, w, integrator=INTEG, height=True)
    Jfd = jacobian_fd(lambda q: cycle_full_map(q, gait, integrator=INTEG), w, 1e-5)
    assert np.max(np.abs(J - Jfd)) < 1e-6
    assert np.max(np.abs(J[0])) < 1e-12
    lam = np.sort(np.abs(np.linalg.eigvals(J)))
    assert lam[0] < 1e-12                                           # the height's
    Jred = sequence_variational_jacobian(gait, Z_DESCENDING, integrator=INTEG)
    rho = np.abs(np.linalg.eigvals(Jred)).max()
    assert lam[-1] == pytest.approx(rho, rel=1e-9)
    assert lam[-1] < 1.0
    assert lam[-1] == pytest.approx(0.2281549, abs=1e-6)     # descending_design's section rho
    # a start off the staircase is pulled back onto it in one cycle
    off, _ = cycle_full_map(w + np.array([0.003, 0, 0, 0]), gait, integrator=INTEG)
    assert abs(off[0]) < 1e-11


def test_a_rise_of_zero_is_no_rise():
    """``rise: 0`` (or none) gives the program of a gait without one, bit for bit, and the
    same cycles; the full map's height is the end's world height."""
    spec = dict(DESCENDING)
    del spec["rise"]
    plain = SequenceGaitSpec.model_validate(spec).gait()
    zero = SequenceGaitSpec.model_validate(dict(spec, rise=0.0)).gait()
    assert plain.rise == 0.0 and zero == plain
    prog, _ = plain.loop_controller().program()
    assert not prog[:, L.S_RISE].any()
    a = sequence_cycles(plain, Z_DESCENDING, cycles=3, integrator=INTEG, max_drop=1.0)
    b = sequence_cycles(dataclasses.replace(descending(), rise=0.0), Z_DESCENDING, cycles=3,
                        integrator=INTEG, max_drop=1.0)
    assert a.run.log.tobytes() == b.run.log.tobytes()
    w = np.r_[0.0, Z_DESCENDING]
    wn, _ = cycle_full_map(w, plain, integrator=INTEG)
    assert wn[0] == a.run.log[a.run.log[:, L.L_ID] == 3][0, L.L_STATE + L.Y]


def test_the_mirror_cycle_keeps_the_rise():
    """An alternating gait (a catch with B, then its mirror image with A) loops over both
    cycles: every row of the loop carries the gait's rise."""
    gait = SequenceGait([Segment("free_end_y", value=0.05),
                         Segment("time", value=0.2, magnets="B")], rise=0.05)
    assert gait.alternates
    prog, _ = gait.loop_controller().program()
    assert prog.shape[0] == 6
    np.testing.assert_array_equal(prog[:, L.S_RISE], 0.05)
    one, _ = gait.controller().program()
    np.testing.assert_array_equal(one[:, L.S_RISE], 0.05)


def test_a_rise_must_be_finite():
    with pytest.raises(ValueError, match="rise"):
        descending(rise=float("nan"))


def test_survival_measures_the_height_from_the_staircase():
    """Survival runs of the descending gait without noise: every run completes its 40 cycles
    4 m below its start, and its height drift (from the staircase) is 0 to the integrator's
    accuracy, within any height tolerance; the default fall (link 1's length below the
    planned height) does not end it."""
    gait = descending()
    prog_gait = dataclasses.replace(gait, theta2=float(Z_DESCENDING[0]))
    r = survival_runs(prog_gait.loop_controller(), cycle_section_state(prog_gait, Z_DESCENDING),
                      Z_DESCENDING, runs=np.arange(2), max_cycles=40, noise=Noise(), seed=1,
                      integrator=INTEG, max_drop=0.61,
                      section=prog_gait.section_observers())
    np.testing.assert_array_equal(r.cycles, [40, 40])
    np.testing.assert_array_equal(r.failure, [0, 0])
    np.testing.assert_allclose(r.height, 0.0, rtol=0, atol=1e-10)
