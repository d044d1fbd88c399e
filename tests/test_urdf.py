"""The planar reduction of a URDF (monkeystudy.urdf, Robot.from_urdf), checked against
Pinocchio on the full AcroMonk URDF and against the AcroMonk lab's direct-collocation
trajectories, which were computed with that URDF."""
from __future__ import annotations

import dataclasses
import gzip
import math
from pathlib import Path

import numpy as np
import pytest

from monkeystudy import Robot
from monkeystudy.urdf import UrdfError, reduce_urdf

ACROMONK = Path(__file__).resolve().parents[1] / "data" / "acromonk"
URDF = ACROMONK / "model" / "acromonk.urdf"
NAMES = dict(links=("hook_1", "link_2"), joints=("virtul_joint_hook_1", "joint_1"),
             far_grip="hook_2")
TRAJECTORIES = ("ZB", "ZF", "BF", "FB")


@pytest.fixture(scope="module")
def reduction():
    return reduce_urdf(URDF, **NAMES)


def swing_terms(link1, link2, g, th1, th2, w1, w2):
    """``(M, C qdot, G)`` of the swing (docs/model.md section 2) with across-offsets.

    Derivation: a link's CG is ``proximal + r u + d n`` with ``u = (sin th, -cos th)`` along
    the link (``th`` its absolute angle from the downward vertical) and ``n = (cos th, sin
    th)`` (``u`` turned +90 degrees), i.e. ``proximal + rho (sin(th + b), -cos(th + b))``
    with ``rho = hypot(r, d)``, ``b = atan2(d, r)``: an in-line CG at distance ``rho``, turned
    by ``b``. Substituting into section 2's equations (``r -> rho``, the CG angles shifted by
    ``b``) and expanding ``rho cos(x + b) = r cos x - d sin x``, ``rho sin(x + b) = r sin x + d
    cos x``::

        k  = m2 L1 (r2 c2 - d2 s2),     ks = m2 L1 (r2 s2 + d2 c2),   J2 = I2 + m2 (r2² + d2²)
        M  = [[I1 + m1 (r1² + d1²) + m2 L1² + J2 + 2 k,  J2 + k], [J2 + k,  J2]]
        Cq̇ = [-ks (2 w1 w2 + w2²),  ks w1²]
        G  = [g (m1 (r1 s1 + d1 c1) + m2 L1 s1) + G2,  G2],   G2 = g m2 (r2 s12 + d2 c12)

    (``d = 0`` gives section 2 exactly.)
    """
    m1, L1, r1, d1, I1 = link1.mass, link1.length, link1.com, link1.com_across, link1.inertia
    m2, r2, d2, I2 = link2.mass, link2.com, link2.com_across, link2.inertia
    s2, c2 = math.sin(th2), math.cos(th2)
    s1, c1 = math.sin(th1), math.cos(th1)
    s12, c12 = math.sin(th1 + th2), math.cos(th1 + th2)
    k = m2 * L1 * (r2 * c2 - d2 * s2)
    ks = m2 * L1 * (r2 * s2 + d2 * c2)
    j2 = I2 + m2 * (r2 * r2 + d2 * d2)
    M = np.array([[I1 + m1 * (r1 * r1 + d1 * d1) + m2 * L1 * L1 + j2 + 2 * k, j2 + k],
                  [j2 + k, j2]])
    cq = np.array([-ks * (2 * w1 * w2 + w2 * w2), ks * w1 * w1])
    g2 = g * m2 * (r2 * s12 + d2 * c12)
    G = np.array([g * (m1 * (r1 * s1 + d1 * c1) + m2 * L1 * s1) + g2, g2])
    return M, cq, G


def model_acceleration(red, q, v, tau_q2, g=9.81, drop_across=False):
    """The URDF joints' accelerations [rad s-2] of the reduced model at URDF joint angles
    ``q``, rates ``v`` and motor torque ``tau_q2`` [N m]."""
    link1, link2 = red.link1, red.link2
    if drop_across:
        link1 = dataclasses.replace(link1, com_across=0.0)
        link2 = dataclasses.replace(link2, com_across=0.0)
    a = red.angles
    th1, th2 = a.model_angles(q[0], q[1])
    M, cq, G = swing_terms(link1, link2, g, th1, th2, v[0], a.theta2_sign * v[1])
    acc = np.linalg.solve(M, np.array([0.0, a.theta2_sign * tau_q2]) - cq - G)
    return np.array([acc[0], a.theta2_sign * acc[1]])


# --- the reduction -------------------------------------------------------------------------------
def test_acromonk_reduction_merges_the_welded_bodies_and_drops_the_world(reduction):
    """Link 2 carries the hook and the IMU welded to it; the base and the bars are the world.
    The masses are the URDF's sums; both links run 0.31401 m down and 0.02 m across the
    hook's frame (the hook_1 -> joint_1 and link_2 -> hook_2 origins, their 0.0221 m offsets
    along the axis dropped); at the URDF's zero both point the same way, turned by
    atan2(-0.02, 0.31401) from the downward vertical (and the base's rpy -1.5708 rounds
    -pi/2 by 3.7e-6 rad)."""
    r = reduction
    assert r.link1.bodies == ("hook_1",)
    assert sorted(r.link2.bodies) == ["IMU", "hook_2", "link_2"]
    assert sorted(r.environment) == ["Base", "stick_1", "stick_2"]
    assert r.link1.mass == pytest.approx(1.0419, rel=1e-15)
    assert r.link2.mass == pytest.approx(0.49759 + 0.1009 + 0.032575, rel=1e-15)
    assert r.link1.length == r.link2.length == pytest.approx(math.hypot(0.31401, 0.02),
                                                              rel=1e-10)
    assert r.angles.theta1_offset == pytest.approx(
        math.atan2(-0.02, 0.31401) + (math.pi / 2 - 1.5708), abs=1e-12)
    assert r.angles.theta2_offset == 0.0 and r.angles.theta2_sign == 1.0
    assert r.normal == (1.0, 0.0, 0.0) and r.plane_y == (0.0, 0.0, 1.0)
    # the hook's CG is 0.020697 m off its frame's y axis, the link's line 0.02 m off at the
    # joint: across the line it lies counter-clockwise of it by the difference in the plane
    assert 0 < r.link1.com < r.link1.length and 0 < r.link2.com < r.link2.length
    assert abs(r.link1.com_across) > 1e-3 and abs(r.link2.com_across) > 1e-3
    assert r.out_of_plane["joint"] == pytest.approx(0.0221, rel=1e-12)


def test_robot_from_urdf_carries_the_reduction(reduction):
    robot = Robot.from_urdf(URDF, **NAMES)
    assert robot.name == "acromonk" and robot.gravity == 9.81
    for link, planar in ((robot.link1, reduction.link1), (robot.link2, reduction.link2)):
        assert (link.mass, link.length, link.com, link.com_across, link.inertia) == (
            planar.mass, planar.length, planar.com, planar.com_across, planar.inertia)
    assert robot.pivot_friction.viscous == robot.joint_friction.viscous == 0.0
    assert Robot.from_urdf(reduction, gravity=9.8, name="x") == dataclasses.replace(
        robot, gravity=9.8, name="x")


# --- against Pinocchio on the full URDF ---------------------------------------------------------
@pytest.fixture(scope="module")
def pinocchio_model():
    """Pinocchio's model of the full URDF (every body, the welded ones as Pinocchio merges
    them itself; no geometry: the meshes are not shipped). The file names its root ``world``
    without declaring it, which urdfdom refuses (Drake and yourdfpy accept it): the only
    change is that declaration."""
    pin = pytest.importorskip("pinocchio")
    text = URDF.read_text()
    head = '<robot\n  name="acromonk">'
    assert text.count(head) == 1
    model = pin.buildModelFromXML(text.replace(head, head + '\n  <link name="world"/>'))
    assert model.nq == model.nv == 2
    assert list(model.names)[1:] == list(NAMES["joints"])
    return pin, model


def pinocchio_terms(pin, model, q, v):
    """Pinocchio's ``(M, C qdot, G)`` at URDF joint angles ``q`` and rates ``v``."""
    data = model.createData()
    M = pin.crba(model, data, q)
    M = np.triu(M) + np.triu(M, 1).T        # crba fills the upper triangle
    G = pin.computeGeneralizedGravity(model, data, q).copy()
    cq = pin.nonLinearEffects(model, data, q, v) - G
    return M, cq, G


def reduced_terms(red, q, v, g, drop_across=False):
    """The reduced model's ``(M, C qdot, G)`` in the URDF's joint coordinates (``dtheta =
    S dq`` with ``S = diag(1, theta2_sign)``, so ``M_q = S M S``, ``C_q = S C``, ``G_q = S
    G``)."""
    link1, link2 = red.link1, red.link2
    if drop_across:
        link1 = dataclasses.replace(link1, com_across=0.0)
        link2 = dataclasses.replace(link2, com_across=0.0)
    a = red.angles
    s = np.array([1.0, a.theta2_sign])
    th1, th2 = a.model_angles(q[0], q[1])
    M, cq, G = swing_terms(link1, link2, g, th1, th2, v[0], s[1] * v[1])
    return s[:, None] * M * s[None, :], s * cq, s * G


def random_states(n=20, seed=40):
    rng = np.random.default_rng(seed)
    return [(rng.uniform(-math.pi, math.pi, 2), rng.uniform(-12.0, 12.0, 2)) for _ in range(n)]


def relative_gaps(red, pin, model, drop_across=False):
    """The largest gaps of M, C qdot and G over 20 random states, each relative to its own
    scale over those states (the largest entry), so a term near zero at one state is not
    divided by its own round-off."""
    g = -model.gravity.linear[2]
    got, want = [], []
    for q, v in random_states():
        got.append(reduced_terms(red, q, v, g, drop_across))
        want.append(pinocchio_terms(pin, model, q, v))
    gaps = []
    for i in range(3):
        a = np.array([x[i] for x in got])
        b = np.array([x[i] for x in want])
        gaps.append(np.abs(a - b).max() / np.abs(b).max())
    return gaps


def test_reduced_model_matches_pinocchio_on_the_full_urdf(reduction, pinocchio_model):
    """Mass matrix, Coriolis/centrifugal and gravity terms at 20 random states agree to
    round-off: 1e-13 of each term's scale (the two evaluate the same rigid bodies by different
    sums of a dozen products, each rounded at 1.1e-16 relative; seen: ~1e-15)."""
    pin, model = pinocchio_model
    assert max(relative_gaps(reduction, pin, model)) < 1e-13


def kernel_gaps(robot, red, pin, model):
    """As :func:`relative_gaps`, for the compiled kernel's swing terms
    (``dynamics.swing_matrices`` of ``robot.params()[0]``): ``M`` and ``C qdot + G``."""
    from monkeystudy.kernel.dynamics import swing_matrices

    p = robot.params()[0]
    a = red.angles
    sign = np.array([1.0, a.theta2_sign])
    got, want = [], []
    for q, v in random_states():
        th1, th2 = a.model_angles(q[0], q[1])
        M, bias = swing_matrices(p, th1, th2, v[0], sign[1] * v[1])
        got.append((sign[:, None] * M * sign[None, :], sign * bias))
        Mp, cq, G = pinocchio_terms(pin, model, q, v)
        want.append((Mp, cq + G))
    return [np.abs(np.array([x[i] for x in got]) - np.array([x[i] for x in want])).max()
            / np.abs(np.array([x[i] for x in want])).max() for i in range(2)]


def test_the_kernel_of_the_urdf_robot_matches_pinocchio(reduction, pinocchio_model):
    """The robot a study runs (``Robot.from_urdf``, its kernel parameter row and the compiled
    swing terms) against Pinocchio on the full URDF, to round-off; with its across-offsets
    dropped the kernel misses by percent (so an offset lost between the reduction and the
    kernel is seen)."""
    pin, model = pinocchio_model
    robot = Robot.from_urdf(URDF, **NAMES, gravity=-model.gravity.linear[2])
    assert max(kernel_gaps(robot, reduction, pin, model)) < 1e-13
    in_line = dataclasses.replace(
        robot, link1=dataclasses.replace(robot.link1, com_across=0.0),
        link2=dataclasses.replace(robot.link2, com_across=0.0))
    assert min(kernel_gaps(in_line, reduction, pin, model)) > 1e-2


def test_dropping_the_across_offsets_disagrees_with_pinocchio(reduction, pinocchio_model):
    """The check can fail: with ``com_across`` set to zero (an in-line model with the same
    along-link CG) the Coriolis and gravity terms are off by far more than round-off."""
    pin, model = pinocchio_model
    gaps = relative_gaps(reduction, pin, model, drop_across=True)
    assert gaps[1] > 1e-2 and gaps[2] > 1e-2


# --- against the lab's direct-collocation trajectories -------------------------------------------
def read_trajectory(name: str) -> dict[str, np.ndarray]:
    path = ACROMONK / "trajectories" / name / f"{name}_traj.csv.gz"
    with gzip.open(path, "rt") as f:
        header = f.readline().strip().split(",")
        values = np.loadtxt(f, delimiter=",")
    return dict(zip(header, values.T))


def knot_values(traj: dict[str, np.ndarray], at=(0.0, 1.0),
                segments: int = 19) -> list[dict[str, float]]:
    """The trajectory's values at its collocation knots, both sides of each (``at`` the
    fractions of each segment: (0, 1) its two knots, (0.5,) its midpoint).

    The files sample (1 ms) a direct-collocation solution of 20 knots at equal intervals over
    the file's duration (``n=20`` in its hyperparameters; the jerk is piecewise linear with
    its kinks at ``k T / 19``): within a segment the state is a cubic Hermite spline
    (positions and velocities cubic, accelerations quadratic) and the torque is linear. A
    least-squares fit of those degrees to a segment's samples (fit residual ~1e-15) gives the
    values at its two knots, which lie between samples.
    """
    t = traj["time"]
    h = t[-1] / segments
    degrees = {"shoulder_pos": 3, "elbow_pos": 3, "shoulder_vel": 3, "elbow_vel": 3,
               "shoulder_acc": 2, "elbow_acc": 2, "elbow_torque": 1}
    out = []
    for k in range(segments):
        s = (t - k * h) / h
        inside = (s > 0.01) & (s < 0.99)
        fits = {c: np.polynomial.Polynomial.fit(s[inside], traj[c][inside], deg,
                                                domain=[0, 1], window=[0, 1])
                for c, deg in degrees.items()}
        for c, f in fits.items():
            assert np.abs(f(s[inside]) - traj[c][inside]).max() <= 1e-12 * max(
                1.0, np.abs(traj[c]).max()), (c, k)
        out.extend({c: float(f(end)) for c, f in fits.items()} for end in at)
    return out


def knot_gaps(red, name, drop_across=False, at=(0.0, 1.0)) -> np.ndarray:
    gaps = []
    for v in knot_values(read_trajectory(name), at):
        acc = model_acceleration(red, (v["shoulder_pos"], v["elbow_pos"]),
                                 (v["shoulder_vel"], v["elbow_vel"]), v["elbow_torque"],
                                 drop_across=drop_across)
        want = np.array([v["shoulder_acc"], v["elbow_acc"]])
        gaps.append(np.abs(acc - want).max() / np.abs(want).max())
    return np.array(gaps)


@pytest.mark.parametrize("name", TRAJECTORIES)
def test_collocation_knots_accelerations_match_the_reduced_model(reduction, name):
    """At a direct-collocation knot the spline's acceleration is the plant's dynamics at the
    knot's state and torque exactly (the collocation defects are at the segment midpoints):
    the reduced model reproduces it at all 20 knots of each trajectory, from either side, to
    1e-9 relative (seen: <= 1.5e-11; the knots lie between samples, and extrapolating the
    fits there costs ~4 digits). This checks the across-offsets nobody here wrote: the lab
    computed these with the URDF (gravity 9.81 m s-2, no joint friction)."""
    gaps = knot_gaps(reduction, name)
    assert len(gaps) == 38 and gaps.max() < 1e-9


@pytest.mark.parametrize("name", TRAJECTORIES)
def test_collocation_midpoints_match_the_reduced_model(reduction, name):
    """At each segment's midpoint the collocation constraint holds the spline's derivative
    to the plant's dynamics, up to the solver's tolerance: 1e-8 relative (seen: <= 1.9e-10).
    Between a knot and a midpoint the cubic spline is only an interpolant: at the 1 ms rows
    the reduced model and the file's accelerations differ by up to 1.1 % (docs/model.md)."""
    gaps = knot_gaps(reduction, name, at=(0.5,))
    assert len(gaps) == 19 and gaps.max() < 1e-8


def test_collocation_knots_tell_a_dropped_across_offset(reduction):
    """The same check with ``com_across`` set to zero misses by 60 % or more."""
    assert min(knot_gaps(reduction, name, drop_across=True).max()
               for name in TRAJECTORIES) > 0.3


def test_at_rest_the_first_row_is_the_model_exactly(reduction):
    """Row 0 of the files that start from URDF zero is at rest with no torque, and a knot on
    the sample grid: no fit is needed there, and the model gives its accelerations to
    round-off. (URDF zero is not the hanging equilibrium: both links lean 0.0636 rad and the
    CGs lie off their lines.)"""
    for name in ("ZB", "ZF"):
        traj = read_trajectory(name)
        row = {c: traj[c][0] for c in traj}
        assert row["shoulder_pos"] == row["elbow_pos"] == row["shoulder_vel"] == 0.0
        acc = model_acceleration(reduction, (0.0, 0.0), (0.0, 0.0), row["elbow_torque"])
        want = np.array([row["shoulder_acc"], row["elbow_acc"]])
        np.testing.assert_allclose(acc, want, rtol=1e-12)


# --- refusals -----------------------------------------------------------------------------------
def edited(tmp_path, old, new, count=1):
    text = URDF.read_text()
    assert text.count(old) >= count
    path = tmp_path / "edited.urdf"
    path.write_text(text.replace(old, new, count))
    return path


JOINT_1_AXIS = """<child
      link="link_2" />
    <axis
      xyz="1 0 0" />"""


@pytest.mark.parametrize("old, new, message", [
    (JOINT_1_AXIS, JOINT_1_AXIS.replace("1 0 0", "0 1 0"), "not parallel"),
    ('name="IMU"\n    type="fixed"', 'name="IMU"\n    type="continuous"',
     "two movable joints; also movable: 'IMU'"),
    ('<parent\n      link="hook_1" />', '<parent\n      link="Base" />',
     "motor joint 'joint_1' joins 'Base' -> 'link_2'"),
])
def test_a_urdf_that_is_not_the_planar_chain_is_refused(tmp_path, old, new, message):
    with pytest.raises(UrdfError, match=message):
        reduce_urdf(edited(tmp_path, old, new), **NAMES)


def test_vertical_axes_are_refused(tmp_path):
    text = URDF.read_text().replace('xyz="1 0 0"', 'xyz="0 1 0"')
    path = tmp_path / "vertical.urdf"      # both axes along the hook frame's y: the world's z
    path.write_text(text)
    with pytest.raises(UrdfError, match="not horizontal"):
        reduce_urdf(path, **NAMES)


@pytest.mark.parametrize("names, message", [
    (dict(NAMES, links=("hook_x", "link_2")), "no link 'hook_x' in the URDF"),
    (dict(NAMES, joints=("virtul_joint_hook_1", "elbow")), "no joint 'elbow' in the URDF"),
    (dict(NAMES, links=("link_2", "hook_1")), "moves 'hook_1', not link 1 'link_2'"),
    (dict(NAMES, far_grip="stick_1"), "far grip 'stick_1' must be a link welded"),
    (dict(NAMES, joints=("IMU", "joint_1")), "grip joint 'IMU' is fixed"),
])
def test_wrong_names_are_refused(names, message):
    with pytest.raises(UrdfError, match=message):
        reduce_urdf(URDF, **names)


def test_a_missing_or_malformed_file_is_refused(tmp_path):
    with pytest.raises(UrdfError, match="no such URDF file"):
        reduce_urdf(tmp_path / "none.urdf", **NAMES)
    bad = tmp_path / "bad.urdf"
    for text in ("not xml", "<foo/>"):
        bad.write_text(text)
        with pytest.raises(UrdfError, match="bad.urdf: not a readable URDF"):
            reduce_urdf(bad, **NAMES)
