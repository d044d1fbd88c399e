"""The floquet step: multipliers by variational equations beside finite differences.

The end-to-end cases read the analysis smoke study's datasets (``analysis_smoke``,
tests/study/steps/conftest.py)."""
from __future__ import annotations

import numpy as np
import pytest

from studyhelpers import assert_written_as_declared, open_dataset


def test_floquet_multipliers_and_agreement(analysis_smoke):
    ds = open_dataset(analysis_smoke[0], "floquet.nc")
    assert list(ds["controller"].values) == ["open_loop", "search"]
    lam = ds["multipliers_real"].values + 1j * ds["multipliers_imag"].values
    lam_fd = ds["multipliers_fd_real"].values + 1j * ds["multipliers_fd_imag"].values
    assert np.all(ds["agreement"].values < 1e-7)            # var-eq vs finite differences
    np.testing.assert_allclose(np.abs(lam), np.abs(lam_fd), rtol=1e-6)
    assert np.all(ds["map_defect"].values < 1e-11)
    ol, se = 0, 1
    # the open-loop exact gait is unstable, its leading multiplier ~1.75
    assert ds["stable"].values[ol] == 0 and abs(lam[ol, 0]) == pytest.approx(1.748, abs=2e-3)
    np.testing.assert_array_equal(ds["fixed_point"].values[ol, 0], 0.0)
    assert ds["t_motor"].values[ol] == 0.0
    # the state-based controller: one neutral multiplier (energy), the others inside
    assert ds["stable"].values[se] == 1 and ds["neutral"].values[se] == 1
    assert np.min(np.abs(lam[se] - 1.0)) < 1e-7
    assert np.all(np.abs(lam[se][np.abs(lam[se] - 1.0) > 1e-6]) < 1.0)
    assert ds["t_motor"].values[se] > 0.0


def test_floquet_datasets_are_written_as_declared(analysis_smoke):
    assert_written_as_declared(analysis_smoke[0] / "floquet.nc", "floquet")


#: studies/climbing_gait.yaml on a small grid at the default integrator (rtol 1e-10), with a
#: stability run from the floquet step's fixed point
CLIMBING_DEFAULT = """\
schema_version: 1
name: climbing_default
robot: seed2009
gait:
  kind: sequence
  section: {theta1: 0.0, direction: either, theta2: 1.0}
  segments:
    - {until: free_end_height, value: 0.05, direction: rising, latch_energy: true}
    - {until: energy_restored, value: 0.981, magnets: swap, torque: 0.6354}
steps:
  - {name: map, kind: grid, dtheta1: {start: 4.3, stop: 4.6, num: 7},
     dtheta2: {start: 0.1, stop: 0.4, num: 7}}
  - {name: best, kind: refine, start: {from: map, best: 1}, xatol: 1.0e-10, fatol: 1.0e-18,
     maxiter: 2000, maxfev: 4000}
  - {name: floquet, kind: floquet, from: best}
  - {name: cycles, kind: stability, from: floquet, cycles: 5}
"""


def in_process_pool():
    """A pool running the tasks in this process (what a test patches, they see)."""
    from concurrent.futures import ThreadPoolExecutor

    from monkeystudy.study.pool import Pool
    return Pool(ThreadPoolExecutor(1), 1, "one thread", lambda: None)


def test_a_fixed_point_polished_at_the_default_tolerance_is_run_by_the_next_step(tmp_path):
    from monkeystudy.analysis import cycle_return_map
    from monkeystudy.controllers import Integrator
    from monkeystudy.study import load_study, run_study
    from monkeystudy.study.spec import gait_spec

    from studyhelpers import write_study

    study = load_study(write_study(tmp_path, CLIMBING_DEFAULT, "climbing.yaml"))
    run_study(study, tmp_path / "out", workers=1)
    f = open_dataset(tmp_path / "out", "floquet.nc")
    # Newton's residual stalls near 1e-11 at rtol 1e-10, inside the map's error (~3e-9)
    assert int(f["newton_converged"].values[0]) == 1
    stop = str(f["newton_stop"].values[0])
    assert stop.startswith("converged"), stop
    level = float(f["map_error"].values[0])
    assert 1e-10 < level < 1e-7
    assert float(f["map_defect"].values[0]) <= level
    z = f["fixed_point"].values[0]
    zn, st = cycle_return_map(z, gait_spec(study.study).sequence, integrator=Integrator())
    assert st == 0 and np.linalg.norm(zn - z) <= level
    c = open_dataset(tmp_path / "out", "cycles.nc")
    assert c.attrs["floquet_step"] == "floquet"
    assert int(c.sizes["cycle"]) == 5
    assert_written_as_declared(tmp_path / "out" / "floquet.nc", "floquet")


def test_an_unconverged_polish_is_said_and_refused_by_the_next_step(tmp_path, monkeypatch):
    from monkeystudy.study import load_study, run_study
    from monkeystudy.study.errors import RunFailed
    from monkeystudy.study.progress import Reporter
    from monkeystudy.study.steps import floquet as F

    from studyhelpers import write_study

    newton = F.solve_fixed_point
    # one Newton step from a start 50 Nelder-Mead iterations rough: not converged
    monkeypatch.setattr(F, "solve_fixed_point",
                        lambda *a, **kw: newton(*a, **dict(kw, max_iter=1)))
    text = CLIMBING_DEFAULT.replace("maxiter: 2000, maxfev: 4000", "maxiter: 50")
    study = load_study(write_study(tmp_path, text, "climbing.yaml"))
    lines = []

    class Recorder(Reporter):
        def finish(self, name, message=""):
            lines.append(f"{name}: {message}")

    with pytest.raises(RunFailed) as refused:
        run_study(study, tmp_path / "out", pool=in_process_pool(), reporter=Recorder())
    f = open_dataset(tmp_path / "out", "floquet.nc")
    assert int(f["newton_converged"].values[0]) == 0
    stop = str(f["newton_stop"].values[0])
    assert stop.startswith("not converged: 1 iteration,") and \
        stop.endswith("analysed at its start"), stop
    # the point analysed is the refined start, as said
    best = open_dataset(tmp_path / "out", "best.nc")
    np.testing.assert_array_equal(f["fixed_point"].values[0, 1:],
                                  [float(best["dtheta1"].values.ravel()[0]),
                                   float(best["dtheta2"].values.ravel()[0])])
    # the run's log says so, and the stability step refuses the point with the reason
    assert any(ln.startswith("floquet: sequence: Newton not converged: 1 iteration,")
               for ln in lines), lines
    assert "Newton not converged: 1 iteration," in str(refused.value)


#: AcroMonk's two-swap brachiation (tests/analysis/test_design.py) on the identified model
#: with Coulomb friction at the hook and the elbow; a short refinement (not to a gait)
COULOMB = """\
schema_version: 1
name: coulomb_floquet
robot:
  urdf: {urdf}
  links: [hook_1, link_2]
  joints: [virtul_joint_hook_1, joint_1]
  far_grip: hook_2
  friction: {{pivot: {{coulomb: 0.07865}}, joint: {{viscous: 0.04144, coulomb: 0.02}}}}
gait:
  kind: sequence
  torque_frame: motor
  section: {{theta1: 0.0, direction: either, theta2: 0.15718415}}
  segments:
    - {{until: free_end_y, value: 0.0, direction: falling, torque: -0.36501134, clock: reset}}
    - {{until: time, value: 0.39134575, magnets: swap, torque: 2.58882863}}
    - {{until: coord, coord: theta1, value: 0.0, direction: either}}
    - {{until: free_end_y, value: 0.0, direction: falling, torque: -2.81165613, clock: reset}}
    - {{until: time, value: 0.08122807, magnets: swap, torque: 1.63025727}}
integrator: {{method: dop853, rtol: 1.0e-12, atol: 1.0e-13, max_time: 3.0}}
steps:
  - {{name: best, kind: refine, start: [-7.3971987, 1.7245056], maxfev: 10}}
  - {{name: floquet, kind: floquet, from: best, height_in_map: true}}
"""


def test_a_coulomb_robots_floquet_step_has_both_jacobians(tmp_path):
    """Coulomb friction at the pivot and the joint: the floquet step analyses the map by
    variational equations (saltation matrices at the friction events) beside finite
    differences, and the two spectral radii agree."""
    from pathlib import Path

    from monkeystudy.study import load_study, run_study

    from studyhelpers import write_study

    urdf = Path(__file__).resolve().parents[3] / "data/acromonk/model/acromonk.urdf"
    study = load_study(write_study(tmp_path, COULOMB.format(urdf=urdf), "coulomb.yaml"))
    run_study(study, tmp_path / "out", workers=1)
    f = open_dataset(tmp_path / "out", "floquet.nc")
    assert str(f["failure"].values[0]) == ""
    rho, rho_fd = (float(f[v].values[0]) for v in ("full_spectral_radius",
                                                     "full_spectral_radius_fd"))
    assert np.isfinite(rho) and abs(rho - rho_fd) <= 1e-6 * rho_fd     # 2.54456 both
    assert float(f["agreement"].values[0]) < 1e-8                      # 1.3e-9
