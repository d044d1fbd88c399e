"""Floquet multipliers and fixed points of return maps (finite differences and Newton).

A return map is any callable ``fmap(z) -> (z_next, status)`` on a section
(:mod:`monkeystudy.analysis.sections`). :func:`floquet` differentiates it by fourth-order
central differences; :func:`solve_fixed_point` finds its fixed points by Newton's method with
least-squares steps (a neutral multiplier makes fixed points come in families). The
variational-equation Jacobians are in :mod:`monkeystudy.analysis.variational`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..simulation import Status


def sorted_eigs(J: np.ndarray) -> np.ndarray:
    """Eigenvalues of ``J`` sorted by decreasing modulus (stable for ties)."""
    lam = np.linalg.eigvals(J)
    return lam[np.argsort(-np.abs(lam), kind="stable")]


def jacobian_fd(fmap, z, step: float = 1e-5) -> np.ndarray:
    """Central-difference Jacobian of a return map ``fmap(z) -> (z', status)``.

    Fourth-order (Richardson on steps ``h`` and ``2h``): truncation ~``h^4``, round-off
    ~``delta / h`` with ``delta`` the map's accuracy (~1e-13 at the tight tolerance).
    """
    z = np.asarray(z, float)
    n = z.size
    J = np.empty((n, n))
    for j in range(n):
        h = step * max(1.0, abs(z[j]))
        cols = []
        for hh in (h, 2 * h):
            e = np.zeros(n)
            e[j] = hh
            fp, sp = fmap(z + e)
            fm, sm = fmap(z - e)
            if sp != Status.OK or sm != Status.OK:
                raise RuntimeError("the finite-difference stencil left the gait (status "
                                   f"{Status(sp).name}/{Status(sm).name})")
            cols.append((fp - fm) / (2 * hh))
        J[:, j] = (4 * cols[0] - cols[1]) / 3
    return J


@dataclass
class FloquetResult:
    """Multipliers of a gait's return map on the section ``theta1 = 0``."""

    fixed_point: np.ndarray
    map_defect: float          # |P(z*) - z*|
    jacobian: np.ndarray
    multipliers: np.ndarray    # eigenvalues, sorted by decreasing modulus
    stable: bool               # all |lambda| < 1 (neutral directions excluded, see below)
    neutral: int               # multipliers within 1e-6 of 1 (the energy level for the
                               # state-based controller)


def floquet(fmap, z_star, *, step: float = 1e-5, neutral_tol: float = 1e-6) -> FloquetResult:
    """Floquet multipliers of ``fmap`` at ``z_star`` by finite differences."""
    z_star = np.asarray(z_star, float)
    zn, st = fmap(z_star)
    if st != Status.OK:
        raise RuntimeError(f"no cycle from the fixed point (status {Status(st).name})")
    J = jacobian_fd(fmap, z_star, step)
    lam = np.linalg.eigvals(J)
    lam = lam[np.argsort(-np.abs(lam))]
    neutral = np.abs(lam - 1.0) < neutral_tol
    stable = bool(np.all(np.abs(lam[~neutral]) < 1.0))
    return FloquetResult(z_star, float(np.linalg.norm(zn - z_star)), J, lam, stable,
                         int(neutral.sum()))



@dataclass
class FixedPointResult:
    """Fixed point of a return map by Newton's method.

    ``defect`` is ``|P(z) - z|`` at ``z``, ``history`` the same per iteration (the start
    first), ``jacobian`` the last ``DP(z)`` used, ``map_error`` the map's error level the
    stopping test accepted a residual within (0: none given) and ``message`` why Newton
    stopped (converged or not).
    """

    z: np.ndarray
    defect: float
    converged: bool
    history: list
    jacobian: np.ndarray
    message: str = ""
    map_error: float = 0.0


#: a step that reduces ``|P(z) - z|`` by less than this factor makes no progress
STALL_RATIO = 0.5
#: Newton gives up after this many steps in a row that make no progress
MAX_STALLS = 3


def solve_fixed_point(fmap, z0, *, jacobian=None, rtol: float = 1e-12,
                      map_error: float = 0.0, xtol: float = 1e-13, max_iter: int = 30,
                      rcond: float = 1e-7) -> FixedPointResult:
    """Newton on ``P(z) - z = 0`` with a least-squares step and a backtracking line search.

    A neutral multiplier (the energy level of the state-based controller, which restores
    every cycle's start energy) makes ``DP - I`` singular: fixed points come in a family.
    The minimum-norm step moves across the family, not along it, and still converges
    quadratically to one of its members. ``jacobian(z)`` defaults to finite differences.
    ``rcond``: singular values of ``DP - I`` below ``rcond`` times the largest are taken as
    zero. The neutral one is zero only to the Jacobian's accuracy (~1e-9 by variational
    equations at rtol 1e-12); kept, it would turn the part of ``P(z) - z`` that lies off the
    family's range into a step ~1e9 times too long.

    Stopping test (``|.|`` the 2-norm, ``s = max(1, max|z_i|)``):

    * converged when ``|P(z) - z| <= rtol * s``: the residual target;
    * converged at the map's error level when Newton can go no further and
      ``|P(z) - z| <= map_error``: a step that reduces the residual by less than
      :data:`STALL_RATIO`, a Newton step shorter than ``xtol * s`` (the correction it
      proposes is negligible), no decrease along the step, or ``max_iter`` reached.
      ``map_error`` [units of ``z``] is how far the computed map is from the exact one
      (for an integrated map, the difference from the same map at a tighter tolerance,
      :func:`~monkeystudy.analysis.sections.cycle_map_error`): the computed map is a
      smooth map plus noise of at most that size, so its residual cannot be driven below
      that noise, and a fixed point of the exact map is only known to ``map_error``;
    * not converged: a step shorter than ``xtol * s``, :data:`MAX_STALLS` steps in a row
      without progress, or no decrease along the step, with the residual above both (a
      minimum of ``|P(z) - z|`` that is not a zero, or a map not smooth there), or
      ``max_iter`` reached. ``message`` says which.
    """
    jac = jacobian or (lambda q: jacobian_fd(fmap, q))
    z = np.asarray(z0, float).copy()
    zn, st = fmap(z)
    if st != Status.OK:
        raise RuntimeError(f"no cycle from the start (status {Status(st).name})")
    F = zn - z
    history = [float(np.linalg.norm(F))]
    J = np.full((z.size, z.size), np.nan)
    error_level = float(map_error) if math.isfinite(map_error) else 0.0

    def within(residual: float) -> bool:
        return residual <= max(rtol * max(1.0, float(np.abs(z).max())), error_level)

    def floor_text(why: str) -> str:
        return (f"converged at the map's error level: {why}, |P(z) - z| = {history[-1]:.3g} "
                f"<= map error {error_level:.3g}")

    def short_text(why: str) -> str:
        tol = max(rtol * max(1.0, float(np.abs(z).max())), error_level)
        return (f"not converged: {why}, |P(z) - z| = {history[-1]:.3g} above its tolerance "
                f"{tol:.3g} (rtol max(1, |z|) or the map's error level: a minimum of "
                "|P(z) - z|, not a fixed point, or a map that is not smooth there)")

    stalls = 0
    for _ in range(max_iter):
        J = jac(z)
        step, *_ = np.linalg.lstsq(J - np.eye(z.size), -F, rcond=rcond)
        lam = 1.0
        for _ in range(20):
            zt = z + lam * step
            zn, st = fmap(zt)
            if st == Status.OK and np.linalg.norm(zn - zt) < history[-1]:
                break
            lam *= 0.5
        else:
            if within(history[-1]):
                return FixedPointResult(z, history[-1], True, history, J, floor_text(
                    "no decrease along the Newton step"), error_level)
            return FixedPointResult(z, history[-1], False, history, J, short_text(
                "no decrease along the Newton step"), error_level)
        z = zt
        F = zn - z
        history.append(float(np.linalg.norm(F)))
        scale = max(1.0, float(np.abs(z).max()))
        if history[-1] <= rtol * scale:
            return FixedPointResult(z, history[-1], True, history, J, (
                f"converged: |P(z) - z| = {history[-1]:.3g} <= rtol max(1, |z|) = "
                f"{rtol * scale:.3g}"), error_level)
        short = float(np.linalg.norm(step)) <= xtol * scale
        stalled = history[-1] > STALL_RATIO * history[-2]
        stalls = stalls + 1 if stalled else 0
        if (short or stalled) and history[-1] <= error_level:
            return FixedPointResult(z, history[-1], True, history, J, floor_text(
                "the step made no progress"), error_level)
        if short:
            return FixedPointResult(z, history[-1], False, history, J, short_text(
                f"the step fell below xtol max(1, |z|) = {xtol * scale:.3g}"), error_level)
        if stalls >= MAX_STALLS:
            return FixedPointResult(z, history[-1], False, history, J, short_text(
                f"{MAX_STALLS} steps in a row without progress"), error_level)
    if within(history[-1]):
        return FixedPointResult(z, history[-1], True, history, J, floor_text(
            f"{max_iter} iteration{'' if max_iter == 1 else 's'}"), error_level)
    return FixedPointResult(z, history[-1], False, history, J, (
        f"not converged: {max_iter} iteration{'' if max_iter == 1 else 's'}, |P(z) - z| = {history[-1]:.3g}"), error_level)
