"""Robot parameters: named presets, validation, and the parameter rows the kernels read."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from .kernel.dynamics import derive_params, flipped_params
from .urdf import UrdfReduction, reduce_urdf
from .kernel.layout import (
    N_PARAMS, P_B_JOINT, P_B_PIVOT, P_C_JOINT, P_C_PIVOT, P_G, P_GEAR, P_HOUSING1, P_I1, P_I2,
    P_L1, P_L2, P_M1, P_M2, P_R1, P_R2, P_ROTOR, P_S1, P_S2,
)


def _check_positive(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if value <= 0.0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return value


def _check_nonnegative(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if value < 0.0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return value


@dataclass(frozen=True)
class Link:
    """One link: mass [kg], length [m] (between its proximal and distal points), its CG's
    distance from the proximal point along the link [m], inertia about the CG [kg m^2], and
    the CG's offset across the link [m], counter-clockwise of the line from the proximal to
    the distal point (docs/model.md section 1; 0 for a link whose CG is on that line). Link 1
    carries end A (proximal point = A, distal = the joint), link 2 carries end B (proximal
    point = the joint, distal = B)."""

    mass: float
    length: float
    com: float
    inertia: float
    com_across: float = 0.0

    def validate(self, where: str) -> None:
        _check_positive(f"{where}.mass", self.mass)
        _check_positive(f"{where}.length", self.length)
        _check_positive(f"{where}.inertia", self.inertia)
        across = float(self.com_across)
        if not math.isfinite(across):
            raise ValueError(f"{where}.com_across must be finite, got {across!r}")
        com = float(self.com)
        if not math.isfinite(com):
            raise ValueError(f"{where}.com must be finite, got {com!r}")
        if not 0.0 <= com <= self.length:
            raise ValueError(f"{where}.com must lie on the link, 0 <= com <= length "
                             f"({self.length}), got {com!r}")


@dataclass(frozen=True)
class Friction:
    """Viscous [N m s] and Coulomb [N m] friction of one joint (both zero by default)."""

    viscous: float = 0.0
    coulomb: float = 0.0

    def validate(self, where: str) -> None:
        _check_nonnegative(f"{where}.viscous", self.viscous)
        _check_nonnegative(f"{where}.coulomb", self.coulomb)


@dataclass(frozen=True)
class Rotor:
    """The joint motor's rotor (docs/model.md section 2, "The motor's rotor"): its inertia
    about its own axis [kg m^2], the gear ratio (rotor turns per turn of the joint,
    counted from the link that holds the motor's housing) [1], and that link (1 or 2).

    The rotor turns with the housing's link plus ``gear_ratio`` times the other link's
    angle relative to it, so its kinetic energy adds a constant block to the mass matrix: with
    the housing on link 1, ``inertia * [[1, N], [N, N^2]]`` in ``(theta1, theta2)``; seen from
    the other end, ``N`` becomes ``1 - N``. ``N^2 * inertia`` is the inertia reflected to the
    joint that a datasheet calls the rotor's reflected inertia. Zero inertia (the default)
    is a robot without one.
    """

    inertia: float = 0.0
    gear_ratio: float = 1.0
    housing: int = 1

    def validate(self, where: str) -> None:
        _check_nonnegative(f"{where}.inertia", self.inertia)
        if not math.isfinite(float(self.gear_ratio)):
            raise ValueError(f"{where}.gear_ratio must be finite, got {self.gear_ratio!r}")
        if self.housing not in (1, 2):
            raise ValueError(f"{where}.housing must be 1 or 2 (the link that holds the "
                             f"motor's housing), got {self.housing!r}")

    @property
    def reflected_inertia(self) -> float:
        """``gear_ratio^2 * inertia``: the rotor's inertia seen at the joint [kg m^2]."""
        return self.gear_ratio * self.gear_ratio * self.inertia


@dataclass(frozen=True)
class Motor:
    """The joint motor's limits: the largest torque magnitude it gives [N m] and the largest
    joint speed |dtheta2/dt| it turns at [rad s-1]; inf (the default) where none is stated.

    A robot from a URDF takes its motor joint's ``<limit effort velocity>``. The limits bound
    what a design search may ask of the motor (:class:`~monkeystudy.analysis.
    SegmentDesignSpace`) and a study's gait is checked against them; the simulation itself
    applies the torques it is given.
    """

    torque_limit: float = math.inf
    speed_limit: float = math.inf

    def validate(self, where: str) -> None:
        for name in ("torque_limit", "speed_limit"):
            value = float(getattr(self, name))
            if math.isnan(value) or value <= 0.0:
                raise ValueError(f"{where}.{name} must be > 0 (inf: none), got {value!r}")


@dataclass(frozen=True)
class Robot:
    """The MonkeyBot: two links, gravity [m s-2], friction at the pivot and the joint.

    Build one from a preset (``Robot.preset("seed2009")``) or explicitly; every value is
    checked (``ValueError`` names the parameter).
    """

    link1: Link
    link2: Link
    gravity: float = 9.81
    pivot_friction: Friction = field(default_factory=Friction)
    joint_friction: Friction = field(default_factory=Friction)
    name: str = "custom"
    rotor: Rotor = field(default_factory=Rotor)
    motor: Motor = field(default_factory=Motor)

    def __post_init__(self):
        self.link1.validate("link1")
        self.link2.validate("link2")
        _check_positive("gravity", self.gravity)
        self.pivot_friction.validate("friction.pivot")
        self.joint_friction.validate("friction.joint")
        self.rotor.validate("rotor")
        self.motor.validate("motor")

    # -- presets ---------------------------------------------------------------------------
    @classmethod
    def preset(cls, name: str) -> "Robot":
        try:
            return PRESETS[name]()
        except KeyError:
            raise ValueError(f"unknown robot preset {name!r}; known: {sorted(PRESETS)}") from None

    @classmethod
    def from_urdf(cls, source, *, links: tuple[str, str] | None = None,
                  joints: tuple[str, str] | None = None, far_grip: str | None = None,
                  gravity: float = 9.81, pivot_friction: Friction | None = None,
                  joint_friction: Friction | None = None, name: str | None = None) -> "Robot":
        """The robot of a URDF, reduced to the planar two-link model (docs/model.md
        section 1, "A robot from its URDF"; :func:`monkeystudy.urdf.reduce_urdf` says how).

        Parameters
        ----------
        source : str, Path, yourdfpy.URDF or UrdfReduction
            The URDF file, the parsed URDF, or its reduction (:func:`~monkeystudy.urdf.
            reduce_urdf`, which also gives the angle offsets between the URDF's joint angles
            and ``theta1``, ``theta2``).
        links : (str, str)
            The URDF links that are link 1 (end A, hanging from the grip joint) and link 2.
        joints : (str, str)
            The grip joint (at end A) and the motor joint.
        far_grip : str
            The URDF link welded to link 2 whose frame origin is end B. ``links``,
            ``joints`` and ``far_grip`` are required unless ``source`` is a reduction.
        gravity : float
            Gravitational acceleration [m s-2] (a URDF does not state it).
        pivot_friction, joint_friction : Friction, optional
            Friction at the grip and the motor joint (a URDF without ``<dynamics>`` has none:
            zero unless given).
        name : str, optional
            The robot's label (default: the URDF's robot name).

        The motor's limits are the motor joint's ``<limit effort velocity>``
        (:class:`Motor`; :meth:`with_motor` sets others).

        Raises
        ------
        monkeystudy.urdf.UrdfError
            (a ``ValueError``) a URDF that is not such a two-link robot; the message says why.
        """
        if isinstance(source, UrdfReduction):
            red = source
        elif links is None or joints is None or far_grip is None:
            raise ValueError("a URDF robot needs links (link 1, link 2), joints (grip, motor) "
                             "and far_grip")
        else:
            red = reduce_urdf(source, links=links, joints=joints, far_grip=far_grip)
        lk1, lk2 = (Link(lk.mass, lk.length, lk.com, lk.inertia, lk.com_across)
                    for lk in (red.link1, red.link2))
        return cls(lk1, lk2, gravity=gravity, pivot_friction=pivot_friction or Friction(),
                   joint_friction=joint_friction or Friction(),
                   name=red.name if name is None else name,
                   motor=Motor(red.motor_effort, red.motor_velocity))

    def with_friction(self, pivot: Friction | None = None, joint: Friction | None = None):
        return replace(self, pivot_friction=pivot or self.pivot_friction,
                       joint_friction=joint or self.joint_friction)

    def with_rotor(self, rotor: Rotor) -> "Robot":
        """This robot with the joint motor's rotor ``rotor``."""
        return replace(self, rotor=rotor)

    def with_motor(self, motor: Motor) -> "Robot":
        """This robot with the joint motor's limits ``motor``."""
        return replace(self, motor=motor)

    # -- kernel view -------------------------------------------------------------------------
    def params(self) -> np.ndarray:
        """Parameter rows for the kernels: ``float64[2, N_PARAMS]`` (normal, flipped)."""
        p = np.zeros(N_PARAMS)
        p[P_M1], p[P_M2] = self.link1.mass, self.link2.mass
        p[P_L1], p[P_L2] = self.link1.length, self.link2.length
        p[P_R1], p[P_R2] = self.link1.com, self.link2.com
        p[P_S1], p[P_S2] = self.link1.com_across, self.link2.com_across
        p[P_I1], p[P_I2] = self.link1.inertia, self.link2.inertia
        p[P_G] = self.gravity
        p[P_B_PIVOT], p[P_C_PIVOT] = self.pivot_friction.viscous, self.pivot_friction.coulomb
        p[P_B_JOINT], p[P_C_JOINT] = self.joint_friction.viscous, self.joint_friction.coulomb
        p[P_ROTOR], p[P_GEAR] = self.rotor.inertia, self.rotor.gear_ratio
        p[P_HOUSING1] = 1.0 if self.rotor.housing == 1 else 0.0
        derive_params(p)
        par = np.empty((2, N_PARAMS))
        par[0] = p
        par[1] = flipped_params(p)
        return par

    @property
    def is_mirror_image(self) -> bool:
        """True when the robot seen from end B is the robot seen from end A (mirror-image
        links, and a rotor whose block is the same from both ends): its two parameter rows
        agree in every slot the equations read (the housing's link number is a label that
        changes with the end; the rotor's block it sets is compared)."""
        par = self.params()
        read = np.ones(N_PARAMS, dtype=bool)
        read[P_HOUSING1] = False
        return bool(np.allclose(par[0, read], par[1, read], rtol=0, atol=1e-14))

    def swap_energy_floor(self) -> float:
        """Least potential energy [J] with the free end at the attached end's height.

        On the surface ``L1 cos th1 + L2 cos(th1+th2) = 0`` the potential (attached end at
        y = 0) reduces to ``V = -g cos(th1) (a - m2 r2 L1 / L2)``, with ``|cos th1| <=
        min(1, L2/L1)``, so the minimum is ``-g |a - m2 r2 L1/L2| min(1, L2/L1)``. A swing that
        starts with less total energy and no motor can never reach a swap (energy is conserved
        or dissipated): such grid points are marked unreachable without integrating. With a
        CG off its link's line the least potential on the surface is found numerically
        (:meth:`_swap_floor_off_line`).
        """
        l1, l2 = self.link1, self.link2
        a = l1.mass * l1.com + l2.mass * l1.length
        if l1.com_across or l2.com_across:
            return self._swap_floor_off_line()
        k = a - l2.mass * l2.com * l1.length / l2.length
        return -self.gravity * abs(k) * min(1.0, l2.length / l1.length)

    def _swap_floor_off_line(self) -> float:
        """:meth:`swap_energy_floor` of links whose CGs lie off their lines [J].

        On the surface, ``cos(th1 + th2) = -L1 cos(th1) / L2`` and ``sin(th1 + th2)`` takes
        either sign, so the potential ``g (-a c1 + m1 sigma1 s1 - m2 r2 c12 + m2 sigma2
        s12)`` is a function of ``th1`` on each of two branches: minimised on a grid of each
        interval of ``th1`` where the surface exists, refined by golden sections, its ends
        evaluated, less 1e-12 of its size (a floor must not exceed the least potential).
        """
        l1, l2, g = self.link1, self.link2, self.gravity
        a = l1.mass * l1.com + l2.mass * l1.length
        a_s, b, b_s = l1.mass * l1.com_across, l2.mass * l2.com, l2.mass * l2.com_across
        ratio = l1.length / l2.length

        def potential(th1, branch):
            c1 = np.cos(th1)
            c12 = np.clip(-ratio * c1, -1.0, 1.0)
            s12 = branch * np.sqrt(1.0 - c12 * c12)
            return g * (-a * c1 + a_s * np.sin(th1) - b * c12 + b_s * s12)

        if ratio <= 1.0:
            intervals = [(-math.pi, math.pi)]
        else:                      # the surface exists where |cos th1| <= L2 / L1
            end = math.acos(1.0 / ratio)
            intervals = [(end, math.pi - end), (end - math.pi, -end)]
        best = math.inf
        golden = (math.sqrt(5.0) - 1.0) / 2.0
        for lo, hi in intervals:
            grid = np.linspace(lo, hi, 4097)
            for branch in (1.0, -1.0):
                v = potential(grid, branch)
                best = min(best, float(v.min()), float(v[0]), float(v[-1]))
                k = int(np.argmin(v))
                x0, x1 = grid[max(k - 1, 0)], grid[min(k + 1, grid.size - 1)]
                for _ in range(80):
                    xa = x1 - golden * (x1 - x0)
                    xb = x0 + golden * (x1 - x0)
                    if potential(xa, branch) < potential(xb, branch):
                        x1 = xb
                    else:
                        x0 = xa
                best = min(best, float(potential(0.5 * (x0 + x1), branch)))
        return best - 1e-12 * (1.0 + abs(best))

    def to_dict(self) -> dict:
        """Plain values (JSON-ready): ``link1``, ``link2`` (mass, length, com, inertia, and
        com_across unless it is 0), ``gravity``, ``pivot_friction``, ``joint_friction``
        (viscous, coulomb), ``name``, ``rotor`` (inertia, gear_ratio, housing) unless it
        is the default, none, and ``motor`` (torque_limit [N m], speed_limit [rad s-1], null
        for none) unless it states no limit."""
        d = asdict(self)
        for link in ("link1", "link2"):
            if d[link]["com_across"] == 0.0:
                del d[link]["com_across"]     # an in-line link is described as it always was
        if self.rotor == Rotor():
            del d["rotor"]                    # so is a robot without a rotor
        if self.motor == Motor():
            del d["motor"]                    # and one whose motor states no limit
        else:                                 # JSON has no infinity
            d["motor"] = {k: (None if math.isinf(v) else v) for k, v in d["motor"].items()}
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "Robot":
        """The robot of :meth:`to_dict`'s mapping (a dataset's ``robot`` attribute); missing
        friction is zero, a missing name ``custom``, missing gravity 9.81 m s-2."""
        return cls(Link(**d["link1"]), Link(**d["link2"]), gravity=float(d.get("gravity", 9.81)),
                   pivot_friction=Friction(**d.get("pivot_friction") or {}),
                   joint_friction=Friction(**d.get("joint_friction") or {}),
                   name=str(d.get("name", "custom")), rotor=Rotor(**d.get("rotor") or {}),
                   motor=Motor(**{k: (math.inf if v is None else float(v))
                                  for k, v in (d.get("motor") or {}).items()}))


def _seed2009() -> Robot:
    """The 2009 study's robot as fitted in docs/model.md section 4 (two identical links)."""
    return Robot(Link(1.0, 0.61, 0.543754, 0.01808704), Link(1.0, 0.61, 0.066246, 0.01808704),
                 gravity=9.81, name="seed2009")


def _uniform_rod() -> Robot:
    """Two uniform 1 kg, 0.61 m rods (CG mid-link, I = m L^2 / 12)."""
    L = 0.61
    return Robot(Link(1.0, L, L / 2, L * L / 12), Link(1.0, L, L / 2, L * L / 12),
                 gravity=9.81, name="uniform_rod")


PRESETS = {"seed2009": _seed2009, "uniform_rod": _uniform_rod}

#: The study's motor torque for ``seed2009`` [N m] (docs/model.md section 4).
SEED2009_TORQUE = 0.6354
