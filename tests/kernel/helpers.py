"""Robots, random physical parameters and states shared by the kernel tests."""
from __future__ import annotations

import functools

import numpy as np

from monkeystudy import Friction, Link, Robot, Rotor

#: An asymmetric robot (unequal masses, lengths, CG positions and inertias).
ASYMMETRIC = Robot(Link(1.2, 0.7, 0.42, 0.035), Link(0.8, 0.55, 0.15, 0.02), gravity=9.81,
                   name="asymmetric")

#: Unequal links whose CGs lie off the lines between their joints (as AcroMonk's do).
OFF_LINE = Robot(Link(1.04, 0.315, 0.234, 0.0017, -0.0058),
                 Link(0.63, 0.315, 0.124, 0.0041, 0.0088), gravity=9.81, name="off_line")

#: OFF_LINE with a geared motor's rotor in its joint, the housing on link 1 (seen from end B,
#: on link 2), about as large as a small servo's; a rotor 100 times heavier makes its terms
#: stand out above round-off in every comparison.
GEARED = Robot(OFF_LINE.link1, OFF_LINE.link2, gravity=9.81, name="geared",
               rotor=Rotor(inertia=6e-3, gear_ratio=6.0, housing=1))

ROBOTS = {
    "seed2009": Robot.preset("seed2009"),
    "uniform_rod": Robot.preset("uniform_rod"),
    "asymmetric": ASYMMETRIC,
    "off_line": OFF_LINE,
    "geared": GEARED,
}


def random_link(rng) -> Link:
    m = rng.uniform(0.2, 3.0)
    L = rng.uniform(0.2, 1.5)
    com = rng.uniform(0.0, L)
    inertia = rng.uniform(0.005, 0.3) * m * L * L
    return Link(m, L, com, inertia, rng.uniform(-0.3, 0.3) * L)


def random_robot(rng, friction: bool = False) -> Robot:
    """A physically valid robot with independent random links (generally asymmetric)."""
    fr = {}
    if friction:
        fr = dict(pivot_friction=Friction(rng.uniform(0, 0.8), rng.uniform(0, 0.8)),
                  joint_friction=Friction(rng.uniform(0, 0.8), rng.uniform(0, 0.8)))
    return Robot(random_link(rng), random_link(rng), gravity=rng.uniform(1.0, 25.0), **fr)


def random_state8(rng, vmax: float = 10.0) -> np.ndarray:
    """``[x, y, th1, th2, dx, dy, dth1, dth2]`` with angles over several turns."""
    s = np.empty(8)
    s[0:2] = rng.uniform(-2.0, 2.0, 2)
    s[2:4] = rng.uniform(-2.5 * np.pi, 2.5 * np.pi, 2)
    s[4:6] = rng.uniform(-3.0, 3.0, 2)
    s[6:8] = rng.uniform(-vmax, vmax, 2)
    return s


@functools.lru_cache(maxsize=None)
def reference_robot(name):
    from reference.model import RefRobot
    return RefRobot.from_robot(ROBOTS[name])


@functools.lru_cache(maxsize=None)
def grazing_point(name, u, delta):
    """``(d1, d2)`` along direction ``u`` whose first swing lifts B exactly ``delta`` [m]
    above A at its highest (computed with the reference model)."""
    from reference import model as ref_model
    ref = reference_robot(name)
    prev = None
    for s in np.linspace(0.5, 20.0, 40):
        m = ref_model.first_height_maximum(ref, s * u[0], s * u[1])
        if m is not None and m[1] > 0.0:
            break
        prev = s
    assert prev is not None
    return ref_model.grazing_point(ref, u[0], u[1], delta, prev, s)
