#!/usr/bin/env python3
"""Symbolic differentiation: yasps against SymPy on stable Neo-Hookean.

For the stable Neo-Hookean energy of a tet in its 12 vertex coordinates
(and in the 9 entries of F), prints the time each system takes to derive the
gradient and Hessian symbolically, and the multiplications and additions of
the resulting code: SymPy's after its `cse`, yasps' Hessian kernel after
canonicalisation and CSE (`yasps-count-ops`). The paper reports 500 ms for
yasps and 11 s for SymPy, and 4x SymPy's multiplies for its own code.

Then, on positions, the run time of the code: SymPy's CSE'd gradient and
Hessian printed as C (`ccode`, a loop over instances in the generated file),
compiled with `gcc -O3 -march=native`, loaded with ctypes and called once
for N random tets, against yasps' gradient and Hessian kernels on the same
tets, one thread, after checking that both agree. Needs gcc.

    python3 bench/sympy_compare.py [--count 20000] [--repeat 5]
"""

from __future__ import annotations

import argparse
import ctypes
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Callable, List, Optional, Sequence, Tuple

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "python"))

import numpy as np  # noqa: E402
import sympy as sp  # noqa: E402

import yasps  # noqa: E402
from timing import median  # noqa: E402
from yasps import compiler, energies as E  # noqa: E402
from yasps.emit import emit_scene  # noqa: E402
from yasps.evaluate import _buffer, _compile, DIFFERENTIATION_PIPELINE  # noqa: E402
from yasps.values import from_column_major  # noqa: E402

MU, LAM = 1.0, 10.0


def sympy_snh(F):
    ic = sum(F[i, j] ** 2 for i in range(3) for j in range(3))
    J = F.det()
    alpha = 1 + sp.Rational(3, 4) * MU / LAM
    return MU / 2 * (ic - 3) - MU / 2 * sp.log(ic + 1) + LAM / 2 * (J - alpha) ** 2


#: SymPy's CSE result: (temporary, expression) pairs, then the gradient's
#: and the row-major Hessian's expressions in those temporaries.
Cse = Tuple[List[Tuple[sp.Symbol, sp.Expr]], List[sp.Expr]]


def sympy_derivatives(energy: sp.Expr, variables: Sequence[sp.Symbol]
                      ) -> Tuple[float, Cse]:
    """SymPy's gradient and full Hessian of ``energy`` after ``cse`` (its
    temporaries named t0, t1, ...), and the seconds this took."""
    t0 = time.perf_counter()
    grad = [sp.diff(energy, v) for v in variables]
    hess = [sp.diff(g, v) for g in grad for v in variables]
    result = sp.cse(grad + hess, symbols=sp.numbered_symbols("t"))
    return time.perf_counter() - t0, result


def sympy_counts(cse: Cse) -> Tuple[int, int]:
    """Multiplications (and powers) and additions of a CSE result."""
    replacements, reduced = cse
    ops = sum(sp.count_ops(e, visual=True).subs(sp.Symbol("NEG"), 0)
              for e in [r for _, r in replacements] + reduced)
    counts = {str(k): int(v) for k, v in ops.as_coefficients_dict().items()}
    mul = counts.get("MUL", 0) + counts.get("POW", 0)
    add = counts.get("ADD", 0) + counts.get("SUB", 0)
    return mul, add


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


def random_tets(count: int, seed: int = 0) -> Tuple[np.ndarray, np.ndarray]:
    """Corner positions (count, 4, 3) and rest-shape inverses Dm^-1
    (count, 3, 3) of random non-degenerate tets, drawn as in
    bench/derivatives.py."""
    rng = np.random.default_rng(seed)
    base = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    rest = base[None] + rng.normal(scale=0.05, size=(count, 4, 3))
    cur = rest @ (np.eye(3) + rng.normal(scale=0.2, size=(count, 3, 3)))
    dm_inv = np.linalg.inv(np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2))
    return cur, dm_inv


def snh_on_positions(corners: Optional[np.ndarray] = None,
                     dm_inv: Optional[np.ndarray] = None):
    """Stable Neo-Hookean of tets in their vertex positions: one tet without
    values, or one per entry of ``corners`` (N, 4, 3) with ``dm_inv``."""
    count = 1 if corners is None else len(corners)
    s = yasps.scene("snh")
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=4 * count)
    t = m.addPrimitive("t", numInstances=count)
    x = v.addAttribute("x", rows=3)
    conn = t.addConnectivity("t2v", v, np.arange(4 * count).reshape(count, 4), 4)
    corners_attr = t.addAttribute("c", through=conn, source=x)
    inv = t.addConstant("inv", rows=3, cols=3)
    if corners is not None:
        x.updateValue(corners.reshape(-1, 3))
        inv.updateValue(dm_inv)
    attr = t.addAttribute("e", computed_attribute=E.stable_neo_hookean(
        E.deformation_gradient(corners_attr, inv), MU, LAM, 1.0))
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


def c_source(function: str, inputs: Sequence[Tuple[str, Sequence[sp.Symbol]]],
             cse: Cse, outputs: Sequence[Tuple[str, int]]) -> str:
    """C source of ``void function(long n, const double *in..., double
    *out...)`` that evaluates a CSE result for n instances: input array
    ``name`` holds len(symbols) values per instance, output array ``name``
    the next ``size`` expressions of the CSE result."""
    replacements, reduced = cse
    params = [f"const double *restrict {name}" for name, _ in inputs] + \
        [f"double *restrict {name}" for name, _ in outputs]
    lines = ["#include <math.h>", "",
             f"void {function}(long n, {', '.join(params)}) {{",
             "  for (long i = 0; i < n; ++i) {"]
    for name, symbols in inputs:
        lines += [f"    const double {v} = {name}[{len(symbols)} * i + {k}];"
                  for k, v in enumerate(symbols)]
    lines += [f"    const double {t} = {sp.ccode(e, standard='C99')};"
              for t, e in replacements]
    exprs = iter(reduced)
    for name, size in outputs:
        lines += [f"    {name}[{size} * i + {k}] = {sp.ccode(next(exprs), standard='C99')};"
                  for k in range(size)]
    return "\n".join(lines + ["  }", "}", ""])


def compile_c(source: str, directory: str) -> ctypes.CDLL:
    """Compiles C source with ``gcc -O3 -march=native`` into a shared object
    in ``directory`` and loads it."""
    path = Path(directory) / "sympy_snh.c"
    path.write_text(source)
    subprocess.run(["gcc", "-O3", "-march=native", "-shared", "-fPIC", "-o",
                    str(path.with_suffix(".so")), str(path), "-lm"], check=True)
    return ctypes.CDLL(str(path.with_suffix(".so")))


def yasps_kernels(corners: np.ndarray, dm_inv: np.ndarray
                  ) -> Tuple[float, Callable[[], None], np.ndarray, np.ndarray]:
    """yasps' gradient and Hessian kernels of stable Neo-Hookean on these
    tets: the seconds to compile them, a call that runs both on one thread,
    and their output buffers (flat, column-major per instance)."""
    s, attr = snh_on_positions(corners, dm_inv)
    base = "::".join("@" + n for n in attr.owner.path + [attr.name])
    paths = [base + "__grad", base + "__hess"]
    t0 = time.perf_counter()
    library, _ = _compile(emit_scene(s), paths, s, DIFFERENTIATION_PIPELINE)
    seconds = time.perf_counter() - t0
    n = len(corners)
    outs = [np.empty(n * 12), np.empty(n * 144)]
    buffers = [[_buffer(s, kind, p, out) for kind, p in dict(library.kernels)[path]]
               for path, out in zip(paths, outs)]

    def run() -> None:
        for path, b in zip(paths, buffers):
            library.launch(path, n, b, 1)
    return seconds, run, outs[0], outs[1]


def compare_code(cse: Cse, xs: Sequence[sp.Symbol], ds: Sequence[sp.Symbol],
                 count: int, repeat: int) -> None:
    """Times SymPy's CSE'd gradient + Hessian of stable Neo-Hookean on
    positions, compiled as C, against yasps' kernels on ``count`` tets, after
    checking that they agree, and prints the table."""
    corners, dm_inv = random_tets(count)
    x = np.ascontiguousarray(corners.reshape(count, 12))
    d = np.ascontiguousarray(dm_inv.reshape(count, 9))  # d0..d8 row-major
    g, h = np.empty((count, 12)), np.empty((count, 144))
    with tempfile.TemporaryDirectory(prefix="yasps-sympy-") as tmp:
        t0 = time.perf_counter()
        lib = compile_c(c_source("snh_grad_hess", [("x", xs), ("d", ds)], cse,
                                 [("g", 12), ("h", 144)]), tmp)
        c_compile = time.perf_counter() - t0
        array = np.ctypeslib.ndpointer(np.float64, flags="C_CONTIGUOUS")
        lib.snh_grad_hess.argtypes = [ctypes.c_long] + [array] * 4
        lib.snh_grad_hess.restype = None
        sympy_run = lambda: lib.snh_grad_hess(count, x, d, g, h)  # noqa: E731
        y_compile, yasps_run, y_g, y_h = yasps_kernels(corners, dm_inv)
        sympy_run()
        yasps_run()
        np.testing.assert_allclose(g, y_g.reshape(count, 12), rtol=1e-8,
                                   atol=1e-8 * np.abs(g).max())
        np.testing.assert_allclose(h.reshape(count, 12, 12),
                                   from_column_major(y_h, 12, 12), rtol=1e-8,
                                   atol=1e-8 * np.abs(h).max())
        sympy_time = median(sympy_run, repeat)
        yasps_time = median(yasps_run, repeat)
    per = 1e9 / count
    print()
    print(f"gradient + Hessian of stable Neo-Hookean (x, 12): {count} tets, "
          f"one thread, median of {repeat}")
    print(f"{'code':34s}{'compile':>10s}{'per instance':>15s}{'vs yasps':>10s}")
    print(f"{'SymPy cse, ccode, gcc -O3':34s}{c_compile:9.2f}s"
          f"{sympy_time * per:13.0f}ns{sympy_time / yasps_time:9.2f}x")
    print(f"{'yasps __grad + __hess kernels':34s}{y_compile:9.2f}s"
          f"{yasps_time * per:13.0f}ns{1.0:9.2f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=20000,
                        help="tets for the run-time comparison")
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    xs = sp.symbols("x0:12")
    ds = sp.symbols("d0:9")
    dm = sp.Matrix(3, 3, ds)
    P = sp.Matrix(4, 3, xs)
    Ds = sp.Matrix.hstack(*[(P.row(k) - P.row(0)).T for k in (1, 2, 3)])
    fs = sp.symbols("f0:9")
    cases = [
        ("stable Neo-Hookean (x, 12)", sympy_snh(Ds * dm), xs, snh_on_positions),
        ("stable Neo-Hookean (F, 9)", sympy_snh(sp.Matrix(3, 3, fs)), fs, snh_on_F),
    ]
    print(f"{'energy':30s}{'SymPy diff+cse':>16s}{'yasps diff':>12s}"
          f"{'yasps +codegen':>16s}{'SymPy mul/add':>15s}{'yasps mul/add':>15s}")
    results = {}
    for name, energy, variables, builder in cases:
        s_time, results[name] = sympy_derivatives(energy, variables)
        s_mul, s_add = sympy_counts(results[name])
        y_sym, y_total, y_mul, y_add = yasps_counts(builder)
        print(f"{name:30s}{s_time:15.2f}s{y_sym:11.2f}s{y_total:15.2f}s"
              f"{s_mul:8d}/{s_add:<6d}{y_mul:8d}/{y_add:<6d}")
    print("(yasps counts are of the Hessian kernel, which also computes the "
          "energy; SymPy's cover the gradient and Hessian expressions)")
    compare_code(results[cases[0][0]], xs, ds, args.count, args.repeat)


if __name__ == "__main__":
    main()
