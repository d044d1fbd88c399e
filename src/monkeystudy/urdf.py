"""A two-link robot read from its URDF, reduced to the planar model of docs/model.md section 1.

The URDF is parsed by ``yourdfpy`` (imported on first use: it loads trimesh, ~2 s), without its
meshes: only the kinematic tree (joint origins and axes) and the links' ``<inertial>`` data are
read. :func:`reduce_urdf` returns a :class:`UrdfReduction`: the two planar links, the plane,
the angle offsets between the URDF's joint angles and the model's ``theta1``/``theta2``, and
what the reduction merged and left out. :meth:`monkeystudy.Robot.from_urdf` builds a
:class:`~monkeystudy.Robot` from it.

The reduction (docs/model.md section 1, "A robot from its URDF"):

* The robot is the chain *grip joint -> link 1 -> motor joint -> link 2*, with the far grip
  point a frame welded to link 2. Every other joint must be ``fixed``: a body welded (through
  fixed joints) to the root is the environment (a base, the bars) and is dropped; a body
  welded to link 1 or link 2 (a hook, an IMU) is merged into that link: masses add, the CG is
  the mass-weighted mean, the inertia tensors (rotated into one frame) are carried to the
  common CG by the parallel-axis theorem.
* The plane is normal to the grip joint's axis, which must be horizontal (the URDF's world
  has gravity along -z, as in ROS, Pinocchio and Drake) and parallel to the motor joint's
  axis. The wall plane's normal points along the grip joint's axis, so that a positive URDF
  grip-joint angle turns counter-clockwise in the model's plane (x right, y up).
* Link 1 runs from end A (the grip joint's axis) to the motor joint's axis, link 2 from there
  to the far grip point; ``length`` is the in-plane distance between the two points. A link's
  CG is ``proximal + com u + com_across n`` in the plane, ``u`` the unit vector proximal ->
  distal, ``n`` = ``u`` turned +90 degrees counter-clockwise.
* The inertia is the component about the plane's normal through the link's CG.

Left out, because planar motion about parallel fixed axes does not depend on them: every
offset along the normal (of the CGs, the joint origins and the grip point: the ``out_of_plane``
record reports them), the inertia tensors' other components (they load the bearings, not the
motion), and the URDF's joint limits, efforts and velocities. The URDF carries no friction (no
``<dynamics>`` in AcroMonk's): a study gives it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: two joint axes this close [rad] count as parallel, an axis this close to horizontal as
#: horizontal: URDF exporters round pi/2 to 1.5708 (3.7e-6 rad off), which this tolerates
AXIS_TOLERANCE = 1e-5

#: the URDF world's up (gravity along -z)
WORLD_UP = np.array([0.0, 0.0, 1.0])

_MOVABLE = ("revolute", "continuous")


class UrdfError(ValueError):
    """A URDF that cannot be reduced to the planar two-link model (the message says why)."""


@dataclass(frozen=True)
class PlanarLink:
    """One link of the reduced model: mass [kg], length [m], CG along the link from its
    proximal point (``com``) and across it, counter-clockwise positive (``com_across``) [m],
    inertia about the CG about the plane's normal [kg m^2]; ``bodies`` names the URDF links
    merged into it (the link itself first)."""

    mass: float
    length: float
    com: float
    com_across: float
    inertia: float
    bodies: tuple[str, ...]


@dataclass(frozen=True)
class UrdfAngles:
    """The model's angles from the URDF's joint angles ``q1`` (grip joint), ``q2`` (motor
    joint) [rad]: ``theta1 = q1 + theta1_offset``, ``theta2 = theta2_sign * q2 +
    theta2_offset`` (and the rates ``dtheta1 = dq1``, ``dtheta2 = theta2_sign * dq2``; the
    motor torque ``tau = theta2_sign * tau_q2``). ``theta1_offset`` is the model's ``theta1``
    at the URDF's zero pose (the angle of the line end A -> motor joint from the downward
    vertical, counter-clockwise), ``theta2_offset`` its ``theta2``; ``theta2_sign`` is +1 when
    the motor joint's axis points the grip joint's way, -1 when opposite."""

    theta1_offset: float
    theta2_offset: float
    theta2_sign: float

    def model_angles(self, q1, q2):
        """``(theta1, theta2)`` [rad] of URDF joint angles ``q1``, ``q2`` [rad]."""
        return q1 + self.theta1_offset, self.theta2_sign * q2 + self.theta2_offset

    def urdf_angles(self, theta1, theta2):
        """``(q1, q2)`` [rad] of the model's ``theta1``, ``theta2`` [rad]."""
        return theta1 - self.theta1_offset, self.theta2_sign * (theta2 - self.theta2_offset)


@dataclass(frozen=True)
class UrdfReduction:
    """The planar two-link model of a URDF (see the module docstring).

    ``normal``, ``plane_x``, ``plane_y`` are the plane's normal and its x (right) and y (up)
    axes as unit vectors in the URDF's world frame; ``environment`` names the bodies welded to
    the world (dropped); ``out_of_plane`` maps each reduced point (``end_A``, ``joint``,
    ``end_B``, ``cg1``, ``cg2``) to its offset along ``normal`` from end A [m] (irrelevant to
    planar motion, reported so that a reader sees what was projected away).
    ``motor_effort`` [N m] and ``motor_velocity`` [rad s-1] are the motor joint's ``<limit>``
    (inf where the URDF states none).
    """

    name: str
    link1: PlanarLink
    link2: PlanarLink
    angles: UrdfAngles
    normal: tuple[float, float, float]
    plane_x: tuple[float, float, float]
    plane_y: tuple[float, float, float]
    environment: tuple[str, ...]
    out_of_plane: dict[str, float]
    motor_effort: float = math.inf
    motor_velocity: float = math.inf

    def describe(self) -> str:
        """The reduction in a few lines of text (the numbers docs/model.md quotes)."""
        rows = [f"{self.name}: planar two-link reduction (plane normal {_vec(self.normal)}, "
                f"x {_vec(self.plane_x)}, y {_vec(self.plane_y)} in the URDF world)"]
        for i, lk in ((1, self.link1), (2, self.link2)):
            rows.append(f"link {i} ({' + '.join(lk.bodies)}): mass {lk.mass:.6g} kg, length "
                        f"{lk.length:.6g} m, com {lk.com:.6g} m, com_across "
                        f"{lk.com_across:.6g} m, inertia {lk.inertia:.6g} kg m2")
        a = self.angles
        rows.append(f"angles: theta1 = q1 + {a.theta1_offset:.6g} rad, theta2 = "
                    f"{'' if a.theta2_sign > 0 else '-'}q2 + {a.theta2_offset:.6g} rad")
        rows.append(f"motor joint limits: effort {self.motor_effort:.6g} N m, velocity "
                    f"{self.motor_velocity:.6g} rad s-1")
        rows.append("environment (dropped): " + (", ".join(self.environment) or "none"))
        rows.append("out of plane (dropped) [m]: " + ", ".join(
            f"{k} {v:.6g}" for k, v in self.out_of_plane.items()))
        return "\n".join(rows)


def _vec(v) -> str:
    return "(" + ", ".join(f"{x:.6g}" for x in v) + ")"


def load_urdf(path: str | Path):
    """The parsed URDF at ``path`` (a ``yourdfpy.URDF``, no meshes loaded); ``UrdfError``
    if the file is missing or not a URDF."""
    path = Path(path)
    if not path.is_file():
        raise UrdfError(f"no such URDF file: {path}")
    import yourdfpy  # ~2 s (trimesh): only when a URDF is read

    try:
        return yourdfpy.URDF.load(str(path), build_scene_graph=False, load_meshes=False,
                                  build_collision_scene_graph=False,
                                  load_collision_meshes=False)
    except Exception as exc:  # lxml and yourdfpy raise several kinds for a malformed file
        raise UrdfError(f"{path}: not a readable URDF: {exc}") from None


def check_names(urdf, *, links=None, joints=None, far_grip=None) -> list[tuple[tuple, str]]:
    """Problems with the names a study gives: ``[(key path, message), ...]``, e.g.
    ``(("links", 0), "no link 'x' in the URDF (links: ...)")``; empty when every given name
    exists (``None`` skips a key). The chain itself is checked by :func:`reduce_urdf`."""
    link_names = [lk.name for lk in urdf.robot.links]
    joint_names = [j.name for j in urdf.robot.joints]
    problems = []
    for i, name in enumerate(links or ()):
        if name not in link_names:
            problems.append((("links", i), f"no link {name!r} in the URDF (links: "
                             f"{', '.join(link_names)})"))
    for i, name in enumerate(joints or ()):
        if name not in joint_names:
            problems.append((("joints", i), f"no joint {name!r} in the URDF (joints: "
                             f"{', '.join(joint_names)})"))
    if far_grip is not None and far_grip not in link_names:
        problems.append((("far_grip",), f"no link {far_grip!r} in the URDF (links: "
                         f"{', '.join(link_names)})"))
    return problems


def reduce_urdf(source, *, links: tuple[str, str], joints: tuple[str, str],
                far_grip: str) -> UrdfReduction:
    """The planar two-link model of a URDF (module docstring: the reduction, what is left out).

    Parameters
    ----------
    source : str, Path or yourdfpy.URDF
        The URDF file, or one already parsed by :func:`load_urdf`.
    links : (str, str)
        The URDF links that are link 1 (hanging from the grip joint, end A) and link 2.
    joints : (str, str)
        The grip joint (environment -> link 1, its axis is end A) and the motor joint
        (link 1 -> link 2).
    far_grip : str
        A URDF link welded to link 2 whose frame origin is end B (the other grip).

    Raises
    ------
    UrdfError
        A name that is not in the URDF, a chain that is not grip joint -> link 1 -> motor
        joint -> link 2 -> far grip, a third movable joint, axes that are not parallel or not
        horizontal, a link without mass.
    """
    urdf = source if hasattr(source, "robot") else load_urdf(source)
    links, joints = tuple(links), tuple(joints)
    if len(links) != 2 or len(joints) != 2:
        raise UrdfError("give two links (link 1, link 2) and two joints (grip, motor)")
    problems = check_names(urdf, links=links, joints=joints, far_grip=far_grip)
    if problems:
        raise UrdfError("; ".join(msg for _, msg in problems))
    robot = urdf.robot
    joint = {j.name: j for j in robot.joints}
    parent_joint = {j.child: j for j in robot.joints}
    inertial = {lk.name: lk.inertial for lk in robot.links}
    grip, motor = joint[joints[0]], joint[joints[1]]
    link1, link2 = links

    for role, j in (("grip joint", grip), ("motor joint", motor)):
        if j.type not in _MOVABLE:
            raise UrdfError(f"the {role} {j.name!r} is {j.type}, not revolute or continuous")
    if grip.child != link1:
        raise UrdfError(f"the grip joint {grip.name!r} moves {grip.child!r}, not link 1 "
                        f"{link1!r}: the chain must be grip joint -> link 1 -> motor joint "
                        f"-> link 2 -> far grip")
    if motor.parent != link1 or motor.child != link2:
        raise UrdfError(f"the motor joint {motor.name!r} joins {motor.parent!r} -> "
                        f"{motor.child!r}, not link 1 {link1!r} -> link 2 {link2!r}")
    others = [j for j in robot.joints if j.type != "fixed" and j.name not in joints]
    if others:
        raise UrdfError("a two-link robot has two movable joints; also movable: " + ", ".join(
            f"{j.name!r} ({j.type})" for j in others))

    def welded_group(top: str) -> list[str]:
        group, todo = [], [top]
        while todo:
            name = todo.pop()
            group.append(name)
            todo.extend(j.child for j in robot.joints if j.parent == name and j.type == "fixed")
        return group

    body1, body2 = welded_group(link1), welded_group(link2)
    if far_grip not in body2 or far_grip == link2:
        raise UrdfError(f"the far grip {far_grip!r} must be a link welded (fixed joints) to "
                        f"link 2 {link2!r}; welded to it: {', '.join(body2[1:]) or 'none'}")
    # the grip joint's parent must be welded to the root: the environment
    name = grip.parent
    while name in parent_joint:
        j = parent_joint[name]
        if j.type != "fixed":
            raise UrdfError(f"the grip joint's parent {grip.parent!r} moves with joint "
                            f"{j.name!r}: it must be welded to the world")
        name = j.parent
    environment = tuple(n for n in welded_group(name) if n in inertial)

    # world poses at the URDF's zero configuration (a movable joint adds no rotation at 0)
    pose: dict[str, np.ndarray] = {name: np.eye(4)}

    def pose_of(link: str) -> np.ndarray:
        if link not in pose:
            j = parent_joint[link]
            pose[link] = pose_of(j.parent) @ np.asarray(j.origin, dtype=float)
        return pose[link]

    def axis_of(j) -> np.ndarray:
        a = pose_of(j.child)[:3, :3] @ np.asarray(j.axis, dtype=float)
        norm = np.linalg.norm(a)
        if not norm > 0:
            raise UrdfError(f"joint {j.name!r} has no axis")
        return a / norm

    normal, a2 = axis_of(grip), axis_of(motor)
    if np.linalg.norm(np.cross(normal, a2)) > AXIS_TOLERANCE:
        raise UrdfError(f"the joint axes are not parallel: {grip.name!r} {_vec(normal)}, "
                        f"{motor.name!r} {_vec(a2)} (world frame): the motion is not planar")
    if abs(normal @ WORLD_UP) > AXIS_TOLERANCE:
        raise UrdfError(f"the joint axis {_vec(normal)} is not horizontal (the URDF world "
                        f"has gravity along -z): the model's wall is vertical")
    plane_y = WORLD_UP - (WORLD_UP @ normal) * normal
    plane_y /= np.linalg.norm(plane_y)
    plane_x = np.cross(plane_y, normal)

    def mass_properties(bodies: list[str]) -> tuple[float, np.ndarray, float]:
        """Mass [kg], CG (world) [m] and inertia about the CG about ``normal`` [kg m2]."""
        parts = []
        for b in bodies:
            ine = inertial.get(b)
            if ine is None or not ine.mass:
                continue
            frame = pose_of(b) @ (np.eye(4) if ine.origin is None else ine.origin)
            rot = frame[:3, :3]
            parts.append((float(ine.mass), frame[:3, 3],
                          rot @ np.asarray(ine.inertia, dtype=float) @ rot.T))
        mass = sum(m for m, _, _ in parts)
        if not mass > 0:
            raise UrdfError(f"link {bodies[0]!r} (with {', '.join(bodies[1:]) or 'nothing'} "
                            f"welded to it) has no mass")
        cg = sum(m * c for m, c, _ in parts) / mass
        total = np.zeros((3, 3))
        for m, c, inertia in parts:
            d = c - cg
            total += inertia + m * (d @ d * np.eye(3) - np.outer(d, d))
        return mass, cg, float(normal @ total @ normal)

    m1, cg1, i1 = mass_properties(body1)
    m2, cg2, i2 = mass_properties(body2)
    end_a = pose_of(link1)[:3, 3]
    point = {"end_A": end_a, "joint": pose_of(link2)[:3, 3], "end_B": pose_of(far_grip)[:3, 3],
             "cg1": cg1, "cg2": cg2}
    flat = {k: np.array([(p - end_a) @ plane_x, (p - end_a) @ plane_y])
            for k, p in point.items()}

    def planar(prox, dist, cg, mass, inertia, bodies, which) -> tuple[PlanarLink, np.ndarray]:
        along = dist - prox
        length = float(np.hypot(*along))
        if not length > 0:
            raise UrdfError(f"link {which} has zero length in the plane")
        u = along / length
        n = np.array([-u[1], u[0]])
        rel = cg - prox
        return PlanarLink(mass, length, float(rel @ u), float(rel @ n), inertia,
                          tuple(bodies)), u

    pl1, u1 = planar(flat["end_A"], flat["joint"], flat["cg1"], m1, i1, body1, 1)
    pl2, u2 = planar(flat["joint"], flat["end_B"], flat["cg2"], m2, i2, body2, 2)
    angles = UrdfAngles(theta1_offset=math.atan2(u1[0], -u1[1]),
                        theta2_offset=math.atan2(u1[0] * u2[1] - u1[1] * u2[0], u1 @ u2),
                        theta2_sign=1.0 if normal @ a2 > 0 else -1.0)
    return UrdfReduction(
        name=str(robot.name), link1=pl1, link2=pl2, angles=angles,
        normal=tuple(float(x) for x in normal), plane_x=tuple(float(x) for x in plane_x),
        plane_y=tuple(float(x) for x in plane_y), environment=environment,
        out_of_plane={k: float((p - end_a) @ normal) for k, p in point.items()},
        motor_effort=_limit(motor, "effort"), motor_velocity=_limit(motor, "velocity"))


def _limit(joint, which: str) -> float:
    """A joint's ``<limit>`` attribute ``which`` (``effort`` [N m] or ``velocity``
    [rad s-1]); inf where the URDF states none, or a value that is not positive (no motor
    could move within it)."""
    value = getattr(joint.limit, which, None) if joint.limit is not None else None
    if value is None or not float(value) > 0.0:
        return math.inf
    return float(value)


__all__ = ["AXIS_TOLERANCE", "PlanarLink", "UrdfAngles", "UrdfError", "UrdfReduction",
           "check_names", "load_urdf", "reduce_urdf"]
