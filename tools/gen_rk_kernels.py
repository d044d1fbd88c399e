"""Generate ``src/monkeystudy/kernel/rk_explicit.py``: straight-line RK steps.

The generic stage loops of :mod:`monkeystudy.kernel.integrate` multiply through the zeros of
the tableau and leave LLVM dependent chains it cannot schedule; written out with literal
coefficients (as Hairer's Fortran DOP853 is), a step costs about a third less. The numbers come
from :mod:`monkeystudy.kernel.tableaux`; ``tests/kernel/test_rk_explicit.py`` checks the file is
up to date and agrees with the generic loops.

Usage: ``python tools/gen_rk_kernels.py`` (rewrites the file).
"""
from __future__ import annotations

import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from monkeystudy.kernel import tableaux as T  # noqa: E402

TARGET = ROOT / "src" / "monkeystudy" / "kernel" / "rk_explicit.py"


def lincomb(coeffs, row_expr) -> str:
    terms = [f"{float(c)!r} * {row_expr(j)}" for j, c in enumerate(coeffs) if c != 0.0]
    return " + ".join(terms) if terms else "0.0"


# packed layout: positions then velocities; the vector field's derivative of a position is
# the matching velocity, so only the accelerations need the dynamics
TRIG = ["s1", "c1", "s2", "c2", "s12", "c12"]  # order of layout.T_*
SWING = {"n": 4, "pos": [0, 1], "vel": [2, 3], "accel": "swing_accel", "args": (0, 1, 2, 3)}
FLIGHT = {"n": 8, "pos": [0, 1, 2, 3], "vel": [4, 5, 6, 7], "accel": "flight_accel",
          "args": (2, 3, 6, 7)}


def gen_step(name: str, A, B, ns: int) -> str:
    """A step unrolled into scalars for each packed size (4 swing, 8 flight)."""
    out = []
    for lay in (SWING, FLIGHT):
        n = lay["n"]
        lines = [
            "@njit(cache=True, fastmath=FM, error_model=EM)",
            f"def {name}_step{n}(p, tau, fmode, y, f, h, K, trig, y_new, f_new):",
        ]
        lines += [f"    K[0, {i}] = f[{i}]" for i in range(n)]

        # stage values the field reads: the angles and all velocities (x, y never enter)
        needed = sorted(set(lay["args"]) | set(lay["vel"]))

        def stage_state(coeffs, prefix):
            return [f"    {prefix}{i} = y[{i}] + ({lincomb(coeffs, lambda j: f'K[{j}, {i}]')}) * h"
                    for i in needed]

        def stage_eval(prefix, dest, trig=False):
            acc_names = ["ax", "ay", "a1", "a2"] if n == 8 else ["a1", "a2"]
            args = ", ".join(f"{prefix}{i}" for i in lay["args"])
            if trig:
                code = [f"    {', '.join(acc_names + TRIG)} = {lay['accel']}_trig(p, tau, fmode, "
                        f"{args})"]
                code += [f"    trig[{k}] = {v}" for k, v in enumerate(TRIG)]
            else:
                code = [f"    {', '.join(acc_names)} = {lay['accel']}(p, tau, fmode, {args})"]
            for k, i in enumerate(lay["pos"]):
                code.append(f"    {dest(i)} = {prefix}{lay['vel'][k]}")
            for k, i in enumerate(lay["vel"]):
                code.append(f"    {dest(i)} = {acc_names[k]}")
            return code

        for s in range(1, ns):
            lines += stage_state(A[s, :s], "z")
            lines += stage_eval("z", lambda i, s=s: f"K[{s}, {i}]")
        lines += [f"    y_new[{i}] = y[{i}] + h * ({lincomb(B[:ns], lambda j: f'K[{j}, {i}]')})"
                  for i in range(n)]
        lines += [f"    z{i} = y_new[{i}]" for i in sorted(set(lay["args"]) | set(lay["vel"]))]
        # the last stage (first-same-as-last) also leaves the sines and cosines at the new point
        # for the guards (layout ``T_*``)
        lines += stage_eval("z", lambda i: f"f_new[{i}]", trig=True)
        lines += [f"    K[{ns}, {i}] = f_new[{i}]" for i in range(n)]
        lines.append("")
        out.append("\n".join(lines))
    out.append("\n".join([
        "@njit(cache=True, error_model=EM)",
        f"def {name}_step(phase, p, tau, fmode, y, f, h, n, K, trig, y_new, f_new):",
        f'    """One {name.upper()} step of packed size ``n`` (see ``integrate.rk_step``)."""',
        "    if n == 4:",
        f"        {name}_step4(p, tau, fmode, y, f, h, K, trig, y_new, f_new)",
        "    else:",
        f"        {name}_step8(p, tau, fmode, y, f, h, K, trig, y_new, f_new)",
        f"    return {ns}",
        "",
    ]))
    return "\n\n".join(out)


def gen_error_dop853() -> str:
    e5 = lincomb(T.DOP853_E5, lambda j: f"K[{j}, i]")
    e3 = lincomb(T.DOP853_E3, lambda j: f"K[{j}, i]")
    return f'''@njit(cache=True, fastmath=FM, error_model=EM)
def dop853_error_norm(K, h, y, y_new, n, rtol, atol):
    """DOP853's combined 5th/3rd-order error norm (scipy ``DOP853._estimate_error_norm``)."""
    e5 = 0.0
    e3 = 0.0
    for i in range(n):
        # one division, not two (within an ulp of scipy's err / scale)
        isc = 1.0 / (atol + max(abs(y[i]), abs(y_new[i])) * rtol)
        a5 = ({e5}) * isc
        a3 = ({e3}) * isc
        e5 += a5 * a5
        e3 += a3 * a3
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / math.sqrt((e5 + 0.01 * e3) * n)
'''


def gen_error_rms(name: str, E, doc: str) -> str:
    e = lincomb(E, lambda j: f"K[{j}, i]")
    return f'''@njit(cache=True, fastmath=FM, error_model=EM)
def {name}_error_norm(K, h, y, y_new, n, rtol, atol):
    """{doc}"""
    acc = 0.0
    for i in range(n):
        sc = atol + max(abs(y[i]), abs(y_new[i])) * rtol
        a = ({e}) * h / sc
        acc += a * a
    return math.sqrt(acc / n)
'''


def generate() -> str:
    head = '''"""Straight-line Runge-Kutta steps (GENERATED by tools/gen_rk_kernels.py: do not edit).

Literal coefficients from :mod:`monkeystudy.kernel.tableaux`, zeros dropped. ``FM`` allows only
floating-point contraction (fused multiply-add): it never reassociates sums, so the result is
as accurate as the generic loop (a single rounding per multiply-add instead of two).
"""
import math

from numba import njit

from .dynamics import flight_accel, flight_accel_trig, swing_accel, swing_accel_trig

FM = {"contract"}
# numpy's error model: no division-by-zero test before each division (a singular mass matrix
# gives inf/nan, which the hybrid loop reports as ST_NONFINITE), and without those exception
# paths numba no longer reference-counts the array arguments on every call
EM = "numpy"


'''
    body = [
        gen_step("dop853", T.DOP853_A, T.DOP853_B, T.DOP853_N_STAGES),
        gen_step("rk45", T.RK45_A, T.RK45_B, T.RK45_N_STAGES),
        gen_step("vern9", T.VERN9_A, T.VERN9_B, T.VERN9_N_STAGES),
        gen_error_dop853(),
        gen_error_rms("rk45", T.RK45_E,
                      "RK45's RMS error norm (scipy ``RungeKutta._estimate_error_norm``)."),
        gen_error_rms("vern9", T.VERN9_E,
                      "Vern9's RMS error norm of ``h sum_i E_i k_i`` (scipy's norm, as RK45's)."),
    ]
    return head + "\n\n".join(body)


if __name__ == "__main__":
    TARGET.write_text(generate())
    print(f"wrote {TARGET}")
