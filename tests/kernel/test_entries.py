"""The compiled entry points (``kernel/entries.py``): one per kernel, method and phase set.

* The file is what ``tools/gen_kernel_entries.py`` generates (regenerate after changing a
  kernel's arguments).
* The compile-time choice picks only the asked method's steps, and only the 4-state ones for a
  swing-only program (checked on the overloads' selections, without compiling).
* The API picks the phase set from the program; a swing-only loop that enters flight stops
  with ``ST_NO_FLIGHT_KERNEL`` instead of integrating a flight with the swing steps.
* Each entry point gives what the kernel itself gives (same bits: same arithmetic).
"""
import importlib.util
from pathlib import Path

import numpy as np
import pytest
from numba import types

from monkeystudy.controllers import (
    HorizontalSearch, Integrator, PhaseSequence, Segment, settings_vector,
)
from monkeystudy.kernel import integrate, rk_explicit as rk
from monkeystudy.kernel import layout as L
from monkeystudy.kernel.entries import ENTRY_POINTS, entry_point
from monkeystudy.robot import SEED2009_TORQUE, Robot
from monkeystudy.simulate import (
    evaluate_gaits, hybrid_kernel, initial_state, program_phases, run_controller,
)

ROOT = Path(__file__).resolve().parents[2]
METHODS = {L.METHOD_RK45: "rk45", L.METHOD_DOP853: "dop853", L.METHOD_VERN9: "vern9"}


def test_generated_file_is_up_to_date():
    spec = importlib.util.spec_from_file_location("gen_kernel_entries",
                                                  ROOT / "tools" / "gen_kernel_entries.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    have = (ROOT / "src" / "monkeystudy" / "kernel" / "entries.py").read_text()
    assert have == gen.generate(), "run: python tools/gen_kernel_entries.py"


def test_every_kernel_method_and_phase_set_has_an_entry_point():
    names = {"simulate", "horizontal_gait_batch", "cycle_gait_batch", "cycle_map",
             "fixed_point", "survival_runs"}
    want = {(n, m, p) for n in names for m in METHODS for p in (L.PHASES_SWING, L.PHASES_ANY)}
    assert set(ENTRY_POINTS) == want
    assert entry_point("simulate", float(L.METHOD_VERN9), L.PHASES_ANY).py_func.__name__ == \
        "simulate__vern9_any"


def _closure_functions(impl) -> set[str]:
    """Names of the compiled functions an overload's implementation calls."""
    return {c.cell_contents.py_func.__name__ for c in impl.__closure__ or ()
            if hasattr(c.cell_contents, "py_func")}


@pytest.mark.parametrize("method", sorted(METHODS))
def test_only_the_asked_methods_steps_are_selected(method):
    arr = types.float64[::1]
    args = [arr, types.float64, arr, arr, arr, types.float64, types.int64, types.float64[:, ::1],
            arr, arr, arr, types.float64, types.float64]
    name = METHODS[method]
    swing = integrate._step_error_sq(types.literal(method), types.literal(L.PHASES_SWING),
                                     *args)
    assert _closure_functions(swing) == {f"{name}_step4", f"{name}_error_sq4"}
    both = integrate._step_error_sq(types.literal(method), types.literal(L.PHASES_ANY), *args)
    assert _closure_functions(both) == {f"{name}_step4", f"{name}_error_sq4",
                                        f"{name}_step8", f"{name}_error_sq8"}
    # while the method is still a plain integer, nothing is selected: numba is asked for
    # the literal (compiling no step at all)
    plain = integrate._step_error_sq(types.int64, types.literal(L.PHASES_SWING), *args)
    assert _closure_functions(plain) == set()


def test_dense_output_of_a_swing_only_dop853_loop_is_the_4_state_one():
    impl = integrate._dense_coefficients(types.literal(L.METHOD_DOP853),
                                         types.literal(L.PHASES_SWING), *([types.float64] * 12))
    assert impl.__name__ == "dop853_swing"
    assert rk.dop853_dense4.py_func.__name__ in impl.__code__.co_names


def test_program_phases():
    prog, _ = HorizontalSearch(SEED2009_TORQUE).program()
    assert program_phases(prog) == L.PHASES_SWING            # swaps never fly
    assert program_phases(prog, L.PHASE_FLIGHT) == L.PHASES_ANY
    flies, _ = PhaseSequence([Segment("time", 0.1), Segment("none", magnets="none")]).program()
    assert program_phases(flies) == L.PHASES_ANY
    held, _ = PhaseSequence([Segment("time", 0.1, magnets="A"),
                             Segment("time", 0.2, magnets="both")]).program()
    assert program_phases(held) == L.PHASES_SWING
    # "keep" one magnet and switch the other off can release the last one: may fly
    maybe, _ = PhaseSequence([Segment("time", 0.1, magnets="B")]).program()
    maybe[0, L.S_MAG_A] = -1.0
    maybe[0, L.S_MAG_B] = 0.0
    assert program_phases(maybe) == L.PHASES_ANY


def test_a_swing_only_loop_refuses_to_fly():
    ctrl = PhaseSequence([Segment("time", 0.05), Segment("time", 0.2, magnets="none")],
                         observers=())
    prog, obs = ctrl.program()
    settings = settings_vector(Integrator(), t_end=0.3)
    hyb = initial_state(1.0, 11.0)
    counts = np.zeros(L.N_COUNTS, dtype=np.int64)
    empty = (np.empty((0, L.N_LOG_COLS)), np.empty(0), np.empty((0, 8)),
             np.empty((0, L.N_MODE_COLS)))
    swing_only = entry_point("simulate", L.METHOD_DOP853, L.PHASES_SWING)
    status = swing_only(Robot.preset("seed2009").params(), prog, obs, settings, hyb, counts,
                        np.empty(prog.shape[0]), *empty)
    assert status == L.ST_NO_FLIGHT_KERNEL
    assert hyb[L.H_T] == pytest.approx(0.05)          # stopped where the flight would begin
    # the API chooses the loop that flies, and the program runs to its end, in flight
    run = run_controller(ctrl, initial_state(1.0, 11.0), t_end=0.3)
    assert run.status == L.ST_OK
    assert run.state[L.H_PHASE] == L.PHASE_FLIGHT and run.state[L.H_T] == pytest.approx(0.2)


def test_entry_point_is_the_kernel_with_its_literals():
    """The API's gaits (through ``hybrid_kernel``) equal the entry point called by hand."""
    pts = np.array([[0.902, 10.935], [1.0, 11.0]])
    api = evaluate_gaits(pts, integrator=Integrator("rk45", 1e-8, 1e-10))
    prog, _ = HorizontalSearch(SEED2009_TORQUE).program()
    st = settings_vector(Integrator("rk45", 1e-8, 1e-10))
    assert hybrid_kernel("horizontal_gait_batch", st, prog) is \
        entry_point("horizontal_gait_batch", L.METHOD_RK45, L.PHASES_SWING)
    robot = Robot.preset("seed2009")
    out = np.empty((2, 16))
    entry_point("horizontal_gait_batch", L.METHOD_RK45, L.PHASES_SWING)(
        robot.params(), prog, st, pts, robot.swap_energy_floor(), True, out)
    assert out[:, 0].tobytes() == api["error"].tobytes()
