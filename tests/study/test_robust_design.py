"""A gait written in the motor frame with its height sensed (studies/robust_design.yaml, made
small): torque_frame recorded, the floquet step's full map (height_in_map), the stability
step's torques in the motor frame, the survival step's latency and height_drift; and the
physics of the height a late catch leaves."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from monkeystudy import simulate
from monkeystudy.analysis import cycle_section_state
from monkeystudy.analysis.survival import Noise, survival_runs
from monkeystudy.controllers import Integrator
from monkeystudy.kernel import layout as L
from monkeystudy.kernel.noise import PER_RUN_CYCLE, standard_draw
from monkeystudy.kernel.survival import LATENCY_SLOT
from monkeystudy.study import load_study, run_study
from monkeystudy.study.models import SequenceGaitSpec
from monkeystudy.study.spec import gait_spec

from studyhelpers import assert_written_as_declared
from test_motor_frame import DESIGN_B, Z_B, program_bytes

ROOT = Path(__file__).resolve().parents[2]
TAU_B = (0.3213454663367762, -0.40251722486466324)      # motor frame [N m]
#: the 2009 motor's torque limit [N m]
TAU_MAX = 0.6354

SMALL = """\
schema_version: 1
name: robust_small
robot: seed2009
""" + f"gait: {json.dumps(DESIGN_B)}\n" + """\
integrator: {method: dop853, rtol: 1.0e-12, atol: 1.0e-13, max_time: 3.0}
steps:
  - {name: refine, kind: refine, start: [4.844445533376672, -1.6124995598690839],
     maxiter: 300}
  - {name: floquet, kind: floquet, from: refine, height_in_map: true}
  - {name: cycles, kind: stability, from: floquet, cycles: 5, controller: {tick: 0.001},
     sample_dt: 0.01}
  - name: survival
    kind: survival
    from: floquet
    controller: {tick: 0.001}
    runs: 12
    max_cycles: 30
    seed: 30
    min_advance: 0.5761
    height_tolerance: 0.002
    noise:
      timing: [0.0, 1.0e-3]
      latency: [1.0e-3, 1.0e-3]
      parameters: {mass: 0.01, com: 0.01, inertia: 0.01}
"""


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    folder = tmp_path_factory.mktemp("robust")
    path = folder / "robust_small.yaml"
    path.write_text(SMALL)
    out = folder / "out"
    run_study(load_study(path), out=out, workers=1)
    data = {}
    for name in ("refine", "floquet", "cycles", "survival"):
        with xr.open_dataset(out / f"{name}.nc") as ds:
            data[name] = ds.load()
    return path, data


def test_the_shipped_study_is_design_b_in_the_motor_frame_within_the_motor_limit():
    study = load_study(ROOT / "studies" / "robust_design.yaml").study
    assert study.gait.torque_frame == "motor"
    written = [seg.torque for seg in study.gait.segments] + [study.gait.section.torque]
    assert max(abs(t) for t in written) <= TAU_MAX
    # its gait is design B's (the study starts refine at theta2 = 0.43; the program is the
    # same otherwise)
    design = SequenceGaitSpec.model_validate(dict(DESIGN_B, section=dict(
        DESIGN_B["section"], theta2=study.gait.section.theta2))).gait()
    assert program_bytes(gait_spec(study).sequence) == program_bytes(design)


def test_every_dataset_records_the_torque_frame(small):
    _, data = small
    for name, ds in data.items():
        assert ds.attrs["torque_frame"] == "motor", name
        assert json.loads(ds.attrs["gait"])["torque_frame"] == "motor", name


def test_the_full_map_holds_the_height_and_has_the_reduced_maps_spectral_radius(small):
    ds = small[1]["floquet"]
    assert int(ds.attrs["height_in_map"]) == 1
    assert ds.attrs["full_components"] == "y theta2 dtheta1 dtheta2"
    for v in ("full_jacobian", "full_jacobian_fd", "full_spectral_radius",
              "full_spectral_radius_fd", "full_agreement", "full_stable",
              "full_multipliers_real", "full_multipliers_fd_imag"):
        assert ds[v].attrs["units"] and ds[v].attrs["long_name"], v
    assert ds["full_jacobian"].dims == ("controller", "full_row", "full_col")
    J = ds["full_jacobian"].values[0]
    assert np.max(np.abs(J[0])) < 1e-12                  # the catch sets the next height
    lam = ds["multipliers_real"].values[0] + 1j * ds["multipliers_imag"].values[0]
    rho = float(ds["full_spectral_radius"].values[0])
    assert rho == pytest.approx(np.abs(lam).max(), rel=1e-12)
    assert rho == pytest.approx(0.3041373041, abs=1e-9)
    assert abs(float(ds["full_spectral_radius_fd"].values[0]) - rho) < 1e-6
    assert float(ds["full_agreement"].values[0]) < 1e-6
    assert int(ds["full_stable"].values[0]) == 1


def test_the_stability_run_states_its_torques_in_the_motor_frame(small):
    """Every cycle's samples carry the torques as the study wrote them, +0.3213 N m before
    the catch and -0.4025 N m after it, in odd cycles (hanging from A first) and even ones
    (hanging from B first) alike: the kernel's frame differs between them, the motor frame
    does not."""
    ds = small[1]["cycles"]
    assert "motor frame" in ds["motor_torque"].attrs["long_name"]
    t = ds["time"].values
    tau = ds["motor_torque"].values
    crossings = ds["t_cross"].values
    assert int(ds.attrs["cycles_completed"]) == 5
    for c in range(5):
        t0 = 0.0 if c == 0 else crossings[c - 1]
        inside = (t > t0 + 0.01) & (t < crossings[c] - 0.01)
        values = set(np.round(tau[inside], 12))
        assert values == {0.0, round(TAU_B[0], 12), round(TAU_B[1], 12)}, (c, values)
        before = inside & (tau == TAU_B[0])
        assert set(ds["attached_end"].values[before]) == {c % 2}   # the cycle's start end


def test_survival_writes_the_latency_and_each_runs_height_drift(small):
    path, data = small
    ds = data["survival"]
    np.testing.assert_array_equal(ds["noise_latency"].values, [1e-3, 1e-3])
    assert ds["noise_latency"].attrs["units"] == "s"
    assert ds["height_drift"].dims == ("level", "run")
    assert ds["height_drift"].attrs["units"] == "m"
    assert float(ds.attrs["height_tolerance"]) == 0.002
    done = ds["failure"].values == L.ST_OK
    assert done.all()
    drift = ds["height_drift"].values
    for i in range(2):
        want = np.mean(np.abs(drift[i][done[i]]) <= 0.002)
        assert float(ds["height_within_tolerance"].values[i]) == want
    # the dataset's drift is the survival runs' own height, run by run
    study = load_study(path).study
    gait = gait_spec(study).sequence
    z = ds.attrs
    start = (float(z["start_theta2"]), float(z["dtheta1"]), float(z["dtheta2"]))
    from dataclasses import replace
    ticked = replace(gait, theta2=start[0], tick=1e-3)
    runs = survival_runs(ticked.controller(), cycle_section_state(ticked, start), start,
                         runs=np.arange(12), max_cycles=30,
                         noise=Noise(timing=1e-3, latency=1e-3, mass=0.01, com=0.01,
                                     inertia=0.01),
                         seed=30, integrator=study.integrator.to_integrator(),
                         min_advance=0.5761, max_drop=0.61,
                         section=ticked.section_observer())
    assert runs.height.tobytes() == drift[1].tobytes()


def test_a_late_catch_leaves_the_free_ends_rise_in_the_latency_and_it_does_not_add_up():
    """Design B under a latency L alone (exact timing otherwise): each catch comes L after
    the free end rose through the start's height, so the robot hangs v_y L higher (v_y: the
    free end's rising speed at the catch, 3.387 m/s) - after one step and, since every catch
    is at the same world height, still after five (not five times higher)."""
    gait = SequenceGaitSpec.model_validate(DESIGN_B).gait()
    integ = Integrator(rtol=1e-12, atol=1e-13)
    ds = simulate(gait.controller(), state=cycle_section_state(gait, Z_B), cycles=1,
                  sample_dt=1e-3, integrator=integ)
    catch = float(ds["event_time"].values[(ds["event_id"].values == 1)
                                          & (ds["event_kind"].values == 0)][0])
    i = np.flatnonzero((ds["segment"].values == 1) & (ds["time"].values == catch))[-1]
    th1, th2, w1, w2 = (float(ds[k].values[i]) for k in ("theta1", "theta2", "theta1_dot",
                                                         "theta2_dot"))
    assert float(ds["B"].values[i, 1]) == pytest.approx(0.0, abs=1e-12)
    v_y = 0.61 * np.sin(th1) * w1 + 0.61 * np.sin(th1 + th2) * (w1 + w2)
    assert v_y == pytest.approx(3.387, abs=1e-3)
    runs = np.arange(8)
    latency = np.array([1e-3 * 0.5 * (standard_draw(30, int(k), PER_RUN_CYCLE, LATENCY_SLOT,
                                                    True) + 1.0) for k in runs])
    for cycles, rtol in ((1, 1e-3), (5, 2e-2)):
        r = survival_runs(gait.controller(), cycle_section_state(gait, Z_B), Z_B, runs=runs,
                          max_cycles=cycles, noise=Noise(latency=1e-3), seed=30,
                          integrator=integ, section=gait.section_observer())
        assert np.all(r.cycles == cycles)
        np.testing.assert_allclose(r.height, v_y * latency, rtol=rtol)


def _by_gid(fig, gid: str):
    found = [a for a in fig.findobj() if a.get_gid() == gid]
    assert found, f"no artist with gid {gid!r}"
    return found[0]


def test_the_figures_show_the_full_map_the_motor_frame_torque_and_the_height(small):
    import matplotlib.pyplot as plt

    from monkeystudy.plotting.kinds.floquet import plot_floquet_multipliers
    from monkeystudy.plotting.cycles import plot_pivot_height
    from monkeystudy.plotting.gait import plot_filmstrip
    from monkeystudy.plotting.kinds.survival import plot_height_drift

    data = small[1]
    fl = data["floquet"]
    fig = plot_floquet_multipliers(fl)
    full = fl["full_multipliers_real"].values[0] + 1j * fl["full_multipliers_imag"].values[0]
    points = _by_gid(fig, "full_multipliers_sequence")
    np.testing.assert_array_equal(points.get_offsets(), np.c_[full.real, full.imag])
    title = points.axes.get_title(loc="left")
    assert f"spectral radius {float(fl['full_spectral_radius'].values[0]):.10g}" in title
    assert "full map" in title and "STABLE" in title
    plt.close(fig)

    cyc = data["cycles"]
    fig = plot_filmstrip(cyc)
    torque = _by_gid(fig, "torque")
    assert "motor frame" in torque.axes.get_ylabel()
    assert "1 ms tick" in torque.axes.get_title(loc="left")      # the run's tick, not the gait's
    assert set(np.round(torque.get_ydata(), 12)) == {0.0, round(TAU_B[0], 12),
                                                     round(TAU_B[1], 12)}
    plt.close(fig)
    fig = plot_pivot_height(cyc)
    np.testing.assert_array_equal(_by_gid(fig, "pivot_height_mm").get_ydata(),
                                  cyc["pivot_height"].values * 1e3)
    plt.close(fig)

    sv = data["survival"]
    fig = plot_height_drift(sv)
    done = sv["failure"].values[1] == L.ST_OK
    bars = _by_gid(fig, "height_drift_1")
    assert bars is not None
    counts, _ = np.histogram(sv["height_drift"].values[1][done] * 1e3,
                             bins=np.linspace(*bars.axes.get_xlim(), 2))
    assert counts.sum() == done.sum()
    tol = [line.get_xdata()[0] for line in fig.findobj() if line.get_gid() == "tolerance"]
    assert sorted(tol) == [-2.0, 2.0]
    plt.close(fig)


def test_datasets_with_the_optional_variables_are_written_as_declared(small):
    """The sequence gait's segments, the full map (height_in_map), the motor frame's torque and
    the height tolerance's fraction are declared as the kinds write them."""
    out = small[0].parent / "out"
    for name, kind in (("refine", "refine"), ("floquet", "floquet"), ("cycles", "stability"),
                       ("survival", "survival")):
        assert_written_as_declared(out / f"{name}.nc", kind)
    assert "full_stable" in small[1]["floquet"] and "height_within_tolerance" in small[1]["survival"]
