"""The integration method is a compile-time choice: each method compiles its own steps only."""
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
from monkeystudy.robot import SEED2009_TORQUE, Friction, Robot

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


# A first DOP853 gait compiles no other method's steps and no flight step: checked on the
# cold cache that tests/test_compiling.py's first run leaves (one cold compile for both).


def test_a_run_that_never_flies_compiles_the_swing_field_alone_bit_for_bit():
    # the copies of the vector field and the holding torque that loops without flight call
    # (hybrid.without_flight): the same bits in the phases such a run has
    from monkeystudy.kernel.dynamics import holding_torque, rhs
    from monkeystudy.kernel.hybrid import without_flight
    from monkeystudy.kernel.layout import PHASE_FIXED

    rng = np.random.default_rng(7)
    p = ROBOT.with_friction(Friction(0.05, 0.02), Friction(0.04, 0.03)).params()[0]
    rhs_swing, hold_swing = without_flight(rhs), without_flight(holding_torque)
    assert rhs_swing.py_func.__name__ == "rhs_without_flight"
    for _ in range(50):
        y = rng.uniform(-3.0, 3.0, 8)
        tau = rng.uniform(-1.0, 1.0)
        fmode = rng.choice([-1.0, 0.0, 1.0], 2)
        for phase in (PHASE_SWING, PHASE_FIXED):
            a, b = np.zeros(8), np.zeros(8)
            rhs(phase, p, tau, fmode, y, a)
            rhs_swing(phase, p, tau, fmode, y, b)
            assert a.tobytes() == b.tobytes()
            for k in (0, 1):
                assert (holding_torque(phase, p, tau, fmode, y, k).hex()
                        == hold_swing(phase, p, tau, fmode, y, k).hex())
    # read as False, the flight branch is dropped before typing (tests/kernel/test_jit.py)
    assert rhs_swing.py_func.__globals__["FLIES"] is False
    assert hold_swing.py_func.__globals__["FLIES"] is False


def _run_loop(loop, method, prog, obs, settings, hyb0, n_samp=4096, log_cap=256):
    """One run of a compiled hybrid loop from ``hyb0``: every array it writes."""
    from monkeystudy.kernel import layout as L

    hyb = hyb0.copy()[None]
    counts = np.zeros((1, L.N_COUNTS), np.int64)
    seg_times = np.empty((1, prog.shape[0]))
    log = np.empty((log_cap, L.N_LOG_COLS))
    st, sy, sm = np.empty(n_samp), np.empty((n_samp, 8)), np.empty((n_samp, L.N_MODE_COLS))
    loop(method, ROBOT.params(), prog, obs, settings, hyb, counts, seg_times, log, st, sy, sm)
    n_log, n_s = counts[0, L.K_LOG], counts[0, L.K_SAMPLES]
    return hyb, counts, seg_times, log[:n_log], st[:n_s], sy[:n_s], sm[:n_s]


def guard_value_of_events():
    from monkeystudy.kernel.events import guard_value
    return guard_value


def test_the_loop_built_on_a_second_model_calls_its_kernels_and_gives_the_same_bits():
    """The loop is specialised on the robot's model as on the method: a model made of the
    two-link model's kernels under a name of its own (copies, compiled apart) gives a loop
    whose every callee that calls a model kernel is a copy calling the copies, and three
    cycles of the 2009 gait, sampled and logged, to the same bits as the two-link loop."""
    from monkeystudy.controllers import horizontal_gait
    from monkeystudy.kernel.dynamics import MODEL_KERNELS, TWO_LINK
    from monkeystudy.kernel.hybrid import hybrid_loop, simulate_implementation
    from monkeystudy.kernel.jit import Model, renamed
    from monkeystudy.kernel.layout import K_CYCLES
    from monkeystudy.simulation import initial_state

    twin = Model("twin", {name: renamed(kernel, "twin")
                          for name, kernel in TWO_LINK.kernels.items()})
    assert twin != TWO_LINK and set(twin.kernels) == set(MODEL_KERNELS)
    # the two-link model is every module's own: its loops copy nothing
    own = simulate_implementation(METHOD_RK45, True)
    assert own.__name__ == "hybrid_loop_rk45_flight"
    assert all(own.__globals__[name] is kernel for name, kernel in TWO_LINK.kernels.items()
               if name in own.__globals__)
    assert own.__globals__["guard_value"] is guard_value_of_events()
    built = simulate_implementation(METHOD_RK45, False, twin)
    assert built.__name__ == "hybrid_loop_rk45_swing_twin"
    # the loop's own calls of model kernels read the twin's (without flight: their copies)
    assert built.__globals__["pack"] is twin.kernels["pack"]
    assert built.__globals__["rhs"].py_func.__name__ == "rhs_twin_without_flight"
    # a callee reaching the model through another module is a copy reading the twin's
    guard_value = built.__globals__["guard_value"]
    assert guard_value.py_func.__name__ == "guard_value_twin"
    guard_t = guard_value.py_func.__globals__["guard"].py_func.__globals__["guard_t"]
    assert guard_t.py_func.__name__ == "guard_t_twin"
    assert guard_t.py_func.__globals__["guard_params"] is twin.kernels["guard_params"]
    step4 = built.__globals__["step4"]
    assert step4.py_func.__globals__["swing_accel_fused"] is twin.kernels["swing_accel_fused"]

    gait = horizontal_gait(SEED2009_TORQUE)
    prog, obs = gait.program()
    st = settings_vector(Integrator(method="rk45"), max_cycles=3, sample_dt=1e-3)
    method = kernel_method(st, prog, PHASE_SWING)
    hyb0 = initial_state(1.3, 11.0)
    want = _run_loop(hybrid_loop(METHOD_RK45, False), method, prog, obs, st, hyb0)
    got = _run_loop(hybrid_loop(METHOD_RK45, False, twin), method, prog, obs, st, hyb0)
    assert want[1][0, K_CYCLES] == 3 and want[3].shape[0] > 2 and want[4].shape[0] > 100
    for a, b in zip(want, got):
        assert a.shape == b.shape and a.tobytes() == b.tobytes()
