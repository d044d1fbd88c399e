"""The integration method is a compile-time choice: each method compiles its own steps only."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import typeof
from numba.core.errors import TypingError

from monkeystudy.controllers import (
    HorizontalSearch, Integrator, kernel_method, program_may_fly,
    settings_vector,
)
from monkeystudy.kernel.gait import N_RESULT, horizontal_gait_batch
from monkeystudy.kernel.integrate import choice_of_type, method_scalar
from monkeystudy.kernel.layout import (
    METHOD_DOP853, METHOD_RK45, METHOD_VERN9, PHASE_FLIGHT, PHASE_SWING, S_MAG_A, S_SWAP,
)
from monkeystudy.robot import SEED2009_TORQUE, Robot

ROBOT = Robot.preset("seed2009")
PROG, _ = HorizontalSearch(SEED2009_TORQUE).program()
POINT = np.array([[1.3, 11.0]])


def test_each_method_and_phase_set_is_a_scalar_type_that_names_it():
    kinds = set()
    for method in (METHOD_RK45, METHOD_DOP853, METHOD_VERN9):
        for flies in (True, False):
            scalar = method_scalar(method, flies)
            assert int(scalar) == method
            assert choice_of_type(typeof(scalar)) == (method, flies)
            kinds.add(typeof(scalar))
    assert len(kinds) == 6
    assert choice_of_type(typeof(1)) is None


def test_only_a_release_without_the_swap_or_a_flight_start_can_fly():
    swap_only, _ = HorizontalSearch(SEED2009_TORQUE).program()
    assert not program_may_fly(swap_only, PHASE_SWING)
    assert program_may_fly(swap_only, PHASE_FLIGHT)
    released = swap_only.copy()
    released[1, S_SWAP] = 0.0     # no swap: magnet A turned off on entry
    released[1, S_MAG_A] = 0.0
    assert program_may_fly(released, PHASE_SWING)
    st = settings_vector(Integrator())
    assert choice_of_type(typeof(kernel_method(st, swap_only, PHASE_SWING))) == \
        (METHOD_DOP853, False)
    assert choice_of_type(typeof(kernel_method(st))) == (METHOD_DOP853, True)


def test_a_plain_integer_method_is_refused_at_compile_time():
    st = settings_vector(Integrator())
    out = np.empty((1, N_RESULT))
    with pytest.raises(TypingError):
        horizontal_gait_batch(int(st[0]), ROBOT.params(), PROG, st, POINT,
                              ROBOT.swap_energy_floor(), True, out)
    horizontal_gait_batch(kernel_method(st, PROG, PHASE_SWING), ROBOT.params(), PROG, st, POINT,
                          ROBOT.swap_energy_floor(), True, out)
    assert out[0, 1] == 0   # ST_OK


@pytest.mark.slow
def test_a_dop853_gait_compiles_no_other_method_and_no_flight(tmp_path):
    # a first gait with an empty kernel cache, in a fresh process: the cache then holds what
    # was compiled, DOP853's swing step and none of RK45's or Vern9's, nor a flight step
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    code = ("import numpy as np; from monkeystudy.simulate import evaluate_gaits; "
            "r = evaluate_gaits(np.array([[1.3, 11.0]])); assert r['status'][0] == 0")
    subprocess.run([sys.executable, "-c", code], env=env, check=True, timeout=900)
    cached = {p.name for p in Path(tmp_path).rglob("*.nbi")}
    assert any(n.startswith("rk_explicit.dop853_step4-") for n in cached), sorted(cached)
    assert not any(n.startswith(("rk_explicit.vern9_", "rk_explicit.rk45_",
                                 "rk_explicit.dop853_step8-", "rk_explicit.dop853_dense8-"))
                   for n in cached), sorted(n for n in cached if n.startswith("rk_explicit."))
