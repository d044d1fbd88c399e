"""The integration method is a compile-time choice: each method compiles its own steps only."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numba import typeof
from numba.core.errors import TypingError

from monkeystudy.controllers import HorizontalSearch, Integrator, kernel_method, settings_vector
from monkeystudy.kernel.gait import N_RESULT, horizontal_gait_batch
from monkeystudy.kernel.integrate import METHOD_SCALAR_TYPES, method_of_type, method_scalar
from monkeystudy.kernel.layout import METHOD_DOP853, METHOD_RK45, METHOD_VERN9
from monkeystudy.robot import SEED2009_TORQUE, Robot

ROBOT = Robot.preset("seed2009")
PROG, _ = HorizontalSearch(SEED2009_TORQUE).program()
POINT = np.array([[1.3, 11.0]])


def test_each_method_is_a_scalar_type_that_names_it():
    for method in (METHOD_RK45, METHOD_DOP853, METHOD_VERN9):
        scalar = method_scalar(method)
        assert int(scalar) == method
        assert method_of_type(typeof(scalar)) == method
    assert len(set(METHOD_SCALAR_TYPES.values())) == 3
    assert method_of_type(typeof(1)) is None


def test_a_plain_integer_method_is_refused_at_compile_time():
    st = settings_vector(Integrator())
    out = np.empty((1, N_RESULT))
    with pytest.raises(TypingError):
        horizontal_gait_batch(int(st[0]), ROBOT.params(), PROG, st, POINT,
                              ROBOT.swap_energy_floor(), True, out)
    horizontal_gait_batch(kernel_method(st), ROBOT.params(), PROG, st, POINT,
                          ROBOT.swap_energy_floor(), True, out)
    assert out[0, 1] == 0   # ST_OK


@pytest.mark.slow
def test_a_dop853_gait_compiles_no_other_method(tmp_path):
    # a first gait with an empty kernel cache, in a fresh process: the cache then holds what
    # was compiled, DOP853's steps and none of RK45's or Vern9's
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    code = ("import numpy as np; from monkeystudy.simulate import evaluate_gaits; "
            "r = evaluate_gaits(np.array([[1.3, 11.0]])); assert r['status'][0] == 0")
    subprocess.run([sys.executable, "-c", code], env=env, check=True, timeout=900)
    cached = {p.name for p in Path(tmp_path).rglob("*.nbi")}
    assert any(n.startswith("rk_explicit.dop853_step4-") for n in cached), sorted(cached)
    assert not any(n.startswith(("rk_explicit.vern9_", "rk_explicit.rk45_")) for n in cached), \
        sorted(n for n in cached if n.startswith("rk_explicit."))
