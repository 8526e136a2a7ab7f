#!/usr/bin/env python3
"""Symbolic differentiation: yasps against SymPy on stable Neo-Hookean.

For the stable Neo-Hookean energy of a tet in its 12 vertex coordinates
(and in the 9 entries of F), prints the time each system takes to derive the
gradient and Hessian symbolically, and the multiplications and additions of
the resulting code: SymPy's after its `cse`, yasps' Hessian kernel after
canonicalisation and CSE (`yasps-count-ops`). The paper reports 500 ms for
yasps and 11 s for SymPy, and 4x SymPy's multiplies for its own code.

    python3 bench/sympy_compare.py
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "python"))

import sympy as sp  # noqa: E402

import yasps  # noqa: E402
from yasps import compiler, energies as E  # noqa: E402
from yasps.emit import emit_scene  # noqa: E402
from yasps.evaluate import DIFFERENTIATION_PIPELINE  # noqa: E402

MU, LAM = 1.0, 10.0


def sympy_snh(F):
    ic = sum(F[i, j] ** 2 for i in range(3) for j in range(3))
    J = F.det()
    alpha = 1 + sp.Rational(3, 4) * MU / LAM
    return MU / 2 * (ic - 3) - MU / 2 * sp.log(ic + 1) + LAM / 2 * (J - alpha) ** 2


def sympy_counts(energy, variables):
    t0 = time.perf_counter()
    grad = [sp.diff(energy, v) for v in variables]
    hess = [sp.diff(g, v) for g in grad for v in variables]
    replacements, reduced = sp.cse(grad + hess)
    seconds = time.perf_counter() - t0
    ops = sum(sp.count_ops(e, visual=True).subs(sp.Symbol("NEG"), 0)
              for e in [r for _, r in replacements] + reduced)
    counts = {str(k): int(v) for k, v in ops.as_coefficients_dict().items()}
    mul = counts.get("MUL", 0) + counts.get("POW", 0)
    add = counts.get("ADD", 0) + counts.get("SUB", 0)
    return seconds, mul, add


def yasps_counts(scene_builder):
    s, attr = scene_builder()
    owner = attr.owner
    base = "::".join("@" + n for n in owner.path + [attr.name])
    ir = emit_scene(s)
    native = compiler._module()
    t0 = time.perf_counter()
    compiler.run_pipeline(ir, DIFFERENTIATION_PIPELINE + ",canonicalize,cse")
    symbolic = time.perf_counter() - t0
    t0 = time.perf_counter()
    library = native.compile_cpu(ir, [base + "__hess"], "", 3, "b",
                                 DIFFERENTIATION_PIPELINE)
    total = time.perf_counter() - t0
    counts = library.op_counts(base + "__hess")
    return symbolic, total, counts["mul"], counts["add"]


def snh_on_positions():
    s = yasps.scene("snh")
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=4)
    t = m.addPrimitive("t", numInstances=1)
    x = v.addAttribute("x", rows=3)
    conn = t.addConnectivity("t2v", v, [[0, 1, 2, 3]], 4)
    corners = t.addAttribute("c", through=conn, source=x)
    inv = t.addConstant("inv", rows=3, cols=3)
    attr = t.addAttribute("e", computed_attribute=E.stable_neo_hookean(
        E.deformation_gradient(corners, inv), MU, LAM, 1.0))
    s.addEnergy(attr)
    s.addMinimizeTarget([x])
    return s, attr


def snh_on_F():
    s = yasps.scene("snhF")
    t = s.addMesh("m").addPrimitive("t", numInstances=1)
    F = t.addAttribute("F", rows=3, cols=3)
    attr = t.addAttribute("e", computed_attribute=E.stable_neo_hookean(F, MU, LAM, 1.0))
    s.addEnergy(attr)
    s.addMinimizeTarget([F])
    return s, attr


def main() -> None:
    xs = sp.symbols("x0:12")
    dm = sp.Matrix(3, 3, sp.symbols("d0:9"))
    P = sp.Matrix(4, 3, xs)
    Ds = sp.Matrix.hstack(*[(P.row(k) - P.row(0)).T for k in (1, 2, 3)])
    fs = sp.symbols("f0:9")
    cases = [
        ("stable Neo-Hookean (x, 12)", sympy_snh(Ds * dm), xs, snh_on_positions),
        ("stable Neo-Hookean (F, 9)", sympy_snh(sp.Matrix(3, 3, fs)), fs, snh_on_F),
    ]
    print(f"{'energy':30s}{'SymPy diff+cse':>16s}{'yasps diff':>12s}"
          f"{'yasps +codegen':>16s}{'SymPy mul/add':>15s}{'yasps mul/add':>15s}")
    for name, energy, variables, builder in cases:
        s_time, s_mul, s_add = sympy_counts(energy, variables)
        y_sym, y_total, y_mul, y_add = yasps_counts(builder)
        print(f"{name:30s}{s_time:15.2f}s{y_sym:11.2f}s{y_total:15.2f}s"
              f"{s_mul:8d}/{s_add:<6d}{y_mul:8d}/{y_add:<6d}")
    print("(yasps counts are of the Hessian kernel, which also computes the "
          "energy; SymPy's cover the gradient and Hessian expressions)")


if __name__ == "__main__":
    main()
