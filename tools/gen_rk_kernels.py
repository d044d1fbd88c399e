"""Generate ``src/monkeystudy/kernel/rk_explicit.py``: straight-line RK steps.

The generic stage loops of :mod:`monkeystudy.kernel.integrate` multiply through the zeros of
the tableau and leave LLVM dependent chains it cannot schedule; written out with literal
coefficients (as Hairer's Fortran DOP853 is), a step costs about a third less. The weighted
sums over stored stages are vector operations on whole rows of ``K``
(``intrinsics.combine_rows4``/``8``): numba compiles with LLVM's straight-line (SLP) vectoriser
off, and in scalars these sums were a quarter of a step's instructions. The numbers come from
:mod:`monkeystudy.kernel.tableaux`; ``tests/kernel/test_rk_explicit.py`` checks the file is up
to date and agrees with the generic loops.

Usage: ``python tools/gen_rk_kernels.py`` (rewrites the file).
"""
from __future__ import annotations

import sys
from pathlib import Path


ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from monkeystudy.kernel import tableaux as T  # noqa: E402
from monkeystudy.kernel.dynamics import PACKED_FLIGHT, PACKED_SWING  # noqa: E402

TARGET = ROOT / "src" / "monkeystudy" / "kernel" / "rk_explicit.py"


# packed layout: positions then velocities; the vector field's derivative of a position is
# the matching velocity, so only the accelerations need the dynamics
TRIG = ["s1", "c1", "s2", "c2", "s12", "c12"]  # order of layout.T_*
SWING, FLIGHT = PACKED_SWING, PACKED_FLIGHT  # the room's packed layouts (kernel/dynamics.py)


def needed(lay) -> list[int]:
    """Stage values the field reads: the angles and all velocities (x, y never enter)."""
    return sorted(set(lay["args"]) | set(lay["vel"]))


def literal_tuple(values) -> str:
    return f"({values[0]!r},)" if len(values) == 1 else f"({', '.join(map(repr, values))})"


def combine(lay, coeffs, prefix, rows=None) -> tuple[list[str], list[str]]:
    """``sum_j coeffs_j K[j, :]`` over ``rows`` (default: all) with nonzero weights, in row
    order, by ``intrinsics.combine_rows4``/``8`` (one vector multiply-add per row) into
    ``prefix0 .. prefix{n-1}``: (code, the components' names)."""
    n = lay["n"]
    rows = range(len(coeffs)) if rows is None else rows
    terms = [(j, float(coeffs[j])) for j in rows if coeffs[j] != 0.0]
    if not terms:
        return [], ["0.0"] * n
    names = [f"{prefix}{i}" for i in range(n)]
    code = [f"    {', '.join(names)} = combine_rows{n}(K, {literal_tuple([j for j, _ in terms])}, "
            f"{literal_tuple([c for _, c in terms])})"]
    return code, names


def older_plus_newest(lay, coeffs, prefix) -> tuple[list[str], list[str]]:
    """``sum_j coeffs_j K[j, :]``: the older stages' part as one vector combination (off the
    critical path: those stages are done), the newest stage's term added in scalars, as the
    field has just left it there. Returns (code, each component's sum as an expression)."""
    s = len(coeffs)
    code, older = combine(lay, coeffs, prefix, rows=range(s - 1))
    newest = float(coeffs[s - 1])
    totals = []
    for i in range(lay["n"]):
        if newest == 0.0:
            totals.append(older[i])
        elif older[i] == "0.0":
            totals.append(f"{newest!r} * K[{s - 1}, {i}]")
        else:
            totals.append(f"{older[i]} + {newest!r} * K[{s - 1}, {i}]")
    return code, totals


def stage_state(lay, coeffs, prefix, base="y") -> list[str]:
    """``prefix_i = base_i + (sum_j coeffs_j K[j, i]) h`` for the components the field reads."""
    code, totals = older_plus_newest(lay, coeffs, "o")
    return code + [f"    {prefix}{i} = {base}[{i}] + ({totals[i]}) * h" for i in needed(lay)]


def stage_eval(lay, prefix, dest, trig=False) -> list[str]:
    """The field at the stage values ``prefix_i`` into ``dest(i)`` (positions' rates are the
    velocities); with ``trig``, also the sines and cosines of its angles into ``trig``."""
    n = lay["n"]
    acc_names = ["ax", "ay", "a1", "a2"] if n == 8 else ["a1", "a2"]
    args = ", ".join(f"{prefix}{i}" for i in lay["args"])
    if trig:
        code = [f"    {', '.join(acc_names + TRIG)} = {lay['accel']}_trig_fused(p, tau, fmode, "
                f"{args})"]
        code += [f"    trig[{k}] = {v}" for k, v in enumerate(TRIG)]
    else:
        code = [f"    {', '.join(acc_names)} = {lay['accel']}_fused(p, tau, fmode, {args})"]
    for k, i in enumerate(lay["pos"]):
        code.append(f"    {dest(i)} = {prefix}{lay['vel'][k]}")
    for k, i in enumerate(lay["vel"]):
        code.append(f"    {dest(i)} = {acc_names[k]}")
    return code


def gen_step(name: str, A, B, ns: int) -> str:
    """A step unrolled into scalars for each packed size (4 swing, 8 flight)."""
    out = []
    for lay in (SWING, FLIGHT):
        n = lay["n"]
        lines = [
            "@njit(cache=True, fastmath=FM, error_model=EM, _nrt=False)",
            f"def {name}_step{n}(p, tau, fmode, y, f, h, K, trig, y_new, f_new):",
        ]
        lines += [f"    K[0, {i}] = f[{i}]" for i in range(n)]
        for s in range(1, ns):
            lines += stage_state(lay, A[s, :s], "z")
            lines += stage_eval(lay, "z", lambda i, s=s: f"K[{s}, {i}]")
        code, totals = older_plus_newest(lay, B[:ns], "b")
        lines += code + [f"    y_new[{i}] = y[{i}] + h * ({totals[i]})" for i in range(n)]
        lines += [f"    z{i} = y_new[{i}]" for i in needed(lay)]
        # the last stage (first-same-as-last) also leaves the sines and cosines at the new point
        # for the guards (layout ``T_*``)
        lines += stage_eval(lay, "z", lambda i: f"f_new[{i}]", trig=True)
        lines += [f"    K[{ns}, {i}] = f_new[{i}]" for i in range(n)]
        lines.append("")
        out.append("\n".join(lines))
    out.append(gen_size_dispatch(
        f"{name}_step", "phase, p, tau, fmode, y, f, h, n, K, trig, y_new, f_new",
        f"One {name.upper()} step of packed size ``n`` (see ``integrate.rk_step``).", ns))
    return "\n\n".join(out)


def gen_size_dispatch(name: str, params: str, doc: str, result=None) -> str:
    """A function ``name(params)`` calling ``name4`` or ``name8`` by the packed size ``n``
    (4 swing, 8 flight) with the other parameters but ``phase``; it returns ``result`` if
    given, else what the callee returns."""
    args = ", ".join(a for a in params.split(", ") if a not in ("phase", "n"))
    lines = ["@njit(cache=True, error_model=EM, _nrt=False)", f"def {name}({params}):",
             f'    """{doc}"""', "    if n == 4:"]
    if result is None:
        lines += [f"        return {name}4({args})", f"    return {name}8({args})"]
    else:
        lines += [f"        {name}4({args})", "    else:", f"        {name}8({args})",
                  f"    return {result}"]
    return "\n".join(lines + [""])


def gen_dense_dop853() -> str:
    """DOP853's dense-output preparation unrolled (three extra stages, then the coefficients
    of the 7th-order interpolant), for each packed size, and its dispatcher."""
    A, D = T.DOP853_A, T.DOP853_D
    ns, ne = T.DOP853_N_STAGES, T.DOP853_N_STAGES_EXTENDED
    out = []
    for lay in (SWING, FLIGHT):
        n = lay["n"]
        lines = [
            "@njit(cache=True, fastmath=FM, error_model=EM, _nrt=False)",
            f"def dop853_dense{n}(p, tau, fmode, y_old, y_new, f_new, h, K, Fd):",
            '    """Dense-output coefficients of the last step into ``Fd`` (scipy '
            '``Dop853DenseOutput``);\n    ``K`` holds the step\'s stages, ``K[12]`` its '
            '``f_new``."""',
        ]
        for s in range(ns + 1, ne):
            lines += stage_state(lay, A[s, :s], "z", base="y_old")
            lines += stage_eval(lay, "z", lambda i, s=s: f"K[{s}, {i}]")
        for i in range(n):
            lines += [
                f"    dy = y_new[{i}] - y_old[{i}]",
                f"    Fd[0, {i}] = dy",
                f"    Fd[1, {i}] = h * K[0, {i}] - dy",
                f"    Fd[2, {i}] = 2.0 * dy - h * (f_new[{i}] + K[0, {i}])",
            ]
        for r in range(D.shape[0]):
            code, rowsum = combine(lay, D[r, :ne], f"d{r}_")
            lines += code
            lines += [f"    Fd[{3 + r}, {i}] = h * {rowsum[i]}" for i in range(n)]
        out.append("\n".join(lines) + "\n")
    out.append(gen_size_dispatch(
        "dop853_dense", "p, tau, fmode, y_old, y_new, f_new, h, n, K, Fd",
        ":func:`dop853_dense4` or :func:`dop853_dense8` by packed size ``n``; returns the "
        "extra\n    right-hand-side evaluations.", ne - ns - 1))
    return "\n\n".join(out)


def pairwise(terms: list[str]) -> str:
    """``terms`` summed as a balanced tree (a shorter dependent chain than a running sum)."""
    while len(terms) > 1:
        terms = [f"({terms[k]} + {terms[k + 1]})" if k + 1 < len(terms) else terms[k]
                 for k in range(0, len(terms), 2)]
    return terms[0][1:-1] if terms[0].startswith("(") else terms[0]


def gen_error_sq(name: str, doc: str, estimates, finish: str) -> str:
    """Squared error norms unrolled for each packed size, and their dispatcher.

    ``estimates`` maps a prefix to the weights of one error estimate; ``finish`` is the
    returned expression of the pairwise sums of squares (named by prefix) and ``n``.
    """
    out = []
    for n in (4, 8):
        lines = [
            "@njit(cache=True, fastmath=FM, error_model=EM, _nrt=False)",
            f"def {name}_error_sq{n}(K, h, y, y_new, rtol, atol):",
            f'    """{doc}"""',
        ]
        lay = SWING if n == 4 else FLIGHT
        sums = {}
        for prefix, (E, _) in estimates.items():
            code, sums[prefix] = combine(lay, E, f"w{prefix}")
            lines += code
        for i in range(n):
            # one division, not one per estimate (within an ulp of scipy's err / scale)
            lines.append(f"    isc{i} = 1.0 / (atol + max(abs(y[{i}]), abs(y_new[{i}])) * rtol)")
            for prefix, (E, scaled_by_h) in estimates.items():
                hfac = "(h * isc{i})" if scaled_by_h else "isc{i}"
                lines.append(f"    {prefix}{i} = {sums[prefix][i]} * " + hfac.format(i=i))
        for prefix in estimates:
            lines.append(f"    {prefix} = "
                         + pairwise([f"{prefix}{i} * {prefix}{i}" for i in range(n)]))
        lines += [f"    {line}" for line in finish.format(n=f"{n}.0").splitlines()]
        out.append("\n".join(lines) + "\n")
    out.append(gen_size_dispatch(
        f"{name}_error_sq", "K, h, y, y_new, n, rtol, atol",
        f":func:`{name}_error_sq4` or :func:`{name}_error_sq8` by packed size ``n``."))
    return "\n\n".join(out)


def gen_errors() -> str:
    dop853 = gen_error_sq(
        "dop853",
        "Square of DOP853's combined 5th/3rd-order error norm (scipy "
        "``DOP853._estimate_error_norm``):\n    ``h^2 e5^2 / ((e5 + e3 / 100) n)``, ``e5``, "
        "``e3`` the sums of squares of the scaled estimates.",
        {"e5_": (T.DOP853_E5, False), "e3_": (T.DOP853_E3, False)},
        "if e5_ == 0.0:\n"
        "    return 0.0\n"
        "# e5 / (e5 + e3 / 100) <= 1: no overflow where the norm itself is finite\n"
        "return (h * h) * (e5_ * (e5_ / ((e5_ + 0.01 * e3_) * {n})))",
    )
    rms = []
    for name, E in (("rk45", T.RK45_E), ("vern9", T.VERN9_E)):
        rms.append(gen_error_sq(
            name,
            f"Square of {name.upper()}'s RMS error norm of ``h sum_i E_i k_i`` (scipy's "
            "``RungeKutta._estimate_error_norm``).",
            {"e_": (E, True)},
            "return e_ / {n}",
        ))
    return "\n\n".join([dop853] + rms)


def generate() -> str:
    head = '''"""Straight-line Runge-Kutta steps (GENERATED by tools/gen_rk_kernels.py: do not edit).

Literal coefficients from :mod:`monkeystudy.kernel.tableaux`, zeros dropped. Sums over stored
stages are ``combine_rows4``/``8``: one vector multiply-add per row of ``K``, in row order;
a stage's newest term is added in scalars, straight from the field. ``FM`` allows only
floating-point contraction (fused multiply-add): it never reassociates sums, so the result is
as accurate as the generic loop (a single rounding per multiply-add instead of two).
"""
from .dynamics import (\n    FIELDS,\n)
from .intrinsics import combine_rows4, combine_rows8
from .jit import njit

FM = {"contract"}
# numpy's error model: no division-by-zero test before each division (a singular mass matrix
# gives inf/nan, which the hybrid loop reports as ST_NONFINITE); ``_nrt=False``: nothing here
# allocates, so numba's reference counting of the array arguments is left out (see
# ``kernel/__init__.py``)
EM = "numpy"


'''
    # the room's fields the steps call, by name (one line, as the file has always had them)
    fields = sorted(f"{lay['accel']}{kind}" for lay in (SWING, FLIGHT)
                    for kind in ("_fused", "_trig_fused"))
    head = head.replace("FIELDS", ", ".join(fields))
    body = [
        gen_step("dop853", T.DOP853_A, T.DOP853_B, T.DOP853_N_STAGES),
        gen_step("rk45", T.RK45_A, T.RK45_B, T.RK45_N_STAGES),
        gen_step("vern9", T.VERN9_A, T.VERN9_B, T.VERN9_N_STAGES),
        gen_dense_dop853(),
        gen_errors(),
    ]
    return head + "\n\n".join(body)


if __name__ == "__main__":
    TARGET.write_text(generate())
    print(f"wrote {TARGET}")
