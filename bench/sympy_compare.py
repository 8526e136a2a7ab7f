#!/usr/bin/env python3
"""Symbolic differentiation: yasps against SymPy on every benchmark energy.

For each energy of bench/benchlib/energy_cases.py (inertia with gravity, mass-spring,
stable Neo-Hookean on positions and on F, Baraff-Witkin cloth, dihedral
bending, the IPC barrier on point-point, point-edge, point-triangle and
edge-edge distances, ABD orthogonality, a pendulum in angles), prints the
time each system takes to derive the gradient and Hessian symbolically, and
the multiplications and additions of the resulting code: SymPy's after its
`cse`, yasps' Hessian kernel after canonicalisation and CSE
(`yasps-count-ops`). The paper reports 500 ms for yasps and 11 s for SymPy
on stable Neo-Hookean, and 4x SymPy's multiplies for its own code.

Then the run time of the code: SymPy's CSE'd gradient and Hessian printed
as C (`ccode`, a loop over instances in the generated file), compiled with
`gcc -O3 -march=native`, loaded with ctypes and called once for N random
instances, against yasps' gradient and Hessian kernels on the same
instances, one thread, after checking that both agree. SymPy sees the
barrier's active branch only (every sampled pair is on it). Needs gcc.

    python3 bench/sympy_compare.py [--count 20000] [--repeat 5] [--json PATH]
"""

from __future__ import annotations

import argparse
import ctypes
import os
import re
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Callable, Dict, List, Sequence, Tuple

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))
HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

import numpy as np  # noqa: E402
import sympy as sp  # noqa: E402

from benchlib.energy_cases import CASES, Case, SympyOps, YaspsEnergy, check_agrees  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.timing import median  # noqa: E402
from yasps import compiler  # noqa: E402
from yasps.compiler.pipelines import DIFFERENTIATION_PIPELINE  # noqa: E402
from yasps.ir import emit_scene  # noqa: E402

#: SymPy's CSE result: (temporary, expression) pairs, then the gradient's
#: and the row-major Hessian's expressions in those temporaries.
Cse = Tuple[List[Tuple[sp.Symbol, sp.Expr]], List[sp.Expr]]
#: Named C input arrays and the symbols of one instance's entries.
Inputs = List[Tuple[str, Sequence[sp.Symbol]]]


def sympy_derivatives(energy: sp.Expr, variables: Sequence[sp.Symbol]
                      ) -> Tuple[float, Cse]:
    """SymPy's gradient and full Hessian of ``energy`` after ``cse`` (its
    temporaries named t0, t1, ...), and the seconds this took, starting from
    an empty SymPy cache."""
    sp.core.cache.clear_cache()
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
    counts = {str(k): int(v) for k, v in sp.sympify(ops).as_coefficients_dict().items()}
    mul = counts.get("MUL", 0) + counts.get("POW", 0)
    add = counts.get("ADD", 0) + counts.get("SUB", 0)
    return mul, add


def yasps_counts(energy: YaspsEnergy) -> Tuple[float, float, int, int]:
    """yasps' symbolic differentiation time (with canonicalisation and
    CSE), the time to compile the Hessian kernel from scratch (no cache),
    and that kernel's multiplications and additions."""
    ir = emit_scene(energy.scene)
    native = compiler.native()
    t0 = time.perf_counter()
    compiler.run_pipeline(ir, DIFFERENTIATION_PIPELINE + ",canonicalize,cse")
    symbolic = time.perf_counter() - t0
    t0 = time.perf_counter()
    library = native.compile_cpu(ir, [energy.path("hess")], "", 3, "b",
                                 DIFFERENTIATION_PIPELINE)
    total = time.perf_counter() - t0
    counts = library.op_counts(energy.path("hess"))
    return symbolic, total, counts["mul"], counts["add"]


def sympy_inputs(case: Case) -> Inputs:
    """Symbols for one instance of ``case``: the parameters ``p`` first,
    then the per-instance constants ``c0``, ``c1``, ..."""
    arrays = case.instances(1)
    names = ["p"] + [f"c{j}" for j in range(len(arrays) - 1)]
    return [(name, sp.symbols(f"{name}{'' if name == 'p' else '_'}0:{a.shape[1]}"))
            for name, a in zip(names, arrays)]


def c_source(function: str, inputs: Inputs, cse: Cse,
             outputs: Sequence[Tuple[str, int]]) -> str:
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


def compile_c(source: str, path: Path) -> ctypes.CDLL:
    """Compiles C source with ``gcc -O3 -march=native`` into a shared object
    next to ``path`` (the source file) and loads it."""
    path.write_text(source)
    subprocess.run(["gcc", "-O3", "-march=native", "-shared", "-fPIC", "-o",
                    str(path.with_suffix(".so")), str(path), "-lm"], check=True)
    return ctypes.CDLL(str(path.with_suffix(".so")))


def compare_code(case: Case, inputs: Inputs, cse: Cse, count: int, repeat: int,
                 directory: str) -> Tuple[float, float, float]:
    """Times SymPy's CSE'd gradient + Hessian of ``case``, compiled as C,
    against yasps' gradient and Hessian kernels on ``count`` instances,
    after checking that they agree: gcc's seconds and both times for all
    instances."""
    arrays = [np.ascontiguousarray(a) for a in case.instances(count)]
    n = arrays[0].shape[1]
    g, h = np.empty((count, n)), np.empty((count, n * n))
    t0 = time.perf_counter()
    lib = compile_c(c_source("grad_hess", inputs, cse, [("g", n), ("h", n * n)]),
                    Path(directory) / (re.sub(r"\W+", "_", case.name) + ".c"))
    c_compile = time.perf_counter() - t0
    array = np.ctypeslib.ndpointer(np.float64, flags="C_CONTIGUOUS")
    lib.grad_hess.argtypes = [ctypes.c_long] + [array] * (len(arrays) + 2)
    lib.grad_hess.restype = None
    sympy_run: Callable[[], None] = lambda: lib.grad_hess(count, *arrays, g, h)  # noqa: E731

    energy = case.build(arrays)
    _, _, (grad, hess) = energy.kernels(["grad", "hess"])

    def yasps_run() -> None:
        grad()
        hess()
    sympy_run()
    yasps_run()  # both warm: output pages touched, code loaded
    check_agrees(g, h, energy.derivatives(), rtol=1e-8)
    return c_compile, median(sympy_run, repeat), median(yasps_run, repeat)


#: The table's columns: (header, format in the JSON table, format printed).
#: Derivation and compile times in seconds, run times in ns per instance;
#: each system's multiplications and additions are printed as one column
#: "mul/add".
COLUMNS = [
    ("energy", "", "{:34s}"),
    ("SymPy diff+cse", "{:.2f}s", "{:14.2f}s"),
    ("yasps diff", "{:.2f}s", "{:10.2f}s"),
    ("+codegen", "{:.2f}s", "{:8.2f}s"),
    ("SymPy mul", "{:d}", "{:9d}"),
    ("SymPy add", "{:d}", "/{:<5d}"),
    ("yasps mul", "{:d}", "{:9d}"),
    ("yasps add", "{:d}", "/{:<5d}"),
    ("gcc", "{:.2f}s", "{:6.2f}s"),
    ("SymPy C g+H", "{:.0f}ns", "{:11.0f}ns"),
    ("yasps g+H", "{:.0f}ns", "{:9.0f}ns"),
    ("SymPy/yasps", "{:.2f}x", "{:12.2f}x"),
]
FOOTNOTE = ("(yasps counts are of the Hessian kernel, which also computes the "
            "energy; SymPy's cover the gradient and Hessian expressions)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=20000,
                        help="instances for the run-time comparison")
    parser.add_argument("--repeat", type=int, default=5)
    add_json_argument(parser, "sympy_compare")
    args = parser.parse_args()
    results = Results("sympy_compare")
    results.values.update(count=args.count, repeat=args.repeat)
    ops = SympyOps()
    title = (f"run times: {args.count} instances, one thread, median of "
             f"{args.repeat}; per instance")
    print(title)
    print(f"{'energy':34s}{'SymPy diff+cse':>15s}{'yasps diff':>11s}"
          f"{'+codegen':>9s}{'SymPy mul/add':>15s}{'yasps mul/add':>15s}"
          f"{'gcc':>7s}{'SymPy C g+H':>13s}{'yasps g+H':>11s}{'SymPy/yasps':>13s}")
    derived: Dict[object, Tuple[float, Cse]] = {}
    rows = []
    with tempfile.TemporaryDirectory(prefix="yasps-sympy-") as tmp:
        for case in CASES:
            inputs = sympy_inputs(case)
            # Formulations of one formula (SNH on x and x via F) share
            # SymPy's result.
            if case.formula not in derived:
                energy = case.formula(ops, *[symbols for _, symbols in inputs])
                derived[case.formula] = sympy_derivatives(energy, inputs[0][1])
            s_time, cse = derived[case.formula]
            s_mul, s_add = sympy_counts(cse)
            y_sym, y_total, y_mul, y_add = yasps_counts(case.build(case.instances(1)))
            gcc, sympy_time, yasps_time = compare_code(
                case, inputs, cse, args.count, args.repeat, tmp)
            per = 1e9 / args.count
            row = [case.name, s_time, y_sym, y_total, s_mul, s_add, y_mul,
                   y_add, gcc, sympy_time * per, yasps_time * per,
                   sympy_time / yasps_time]
            rows.append(row)
            print("".join(c[2].format(v) for c, v in zip(COLUMNS, row)),
                  flush=True)
    print(FOOTNOTE)
    results.table("sympy_compare", [c[0] for c in COLUMNS], rows,
                  [c[1] for c in COLUMNS],
                  f"{title[0].upper()}{title[1:]}. {FOOTNOTE}")
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
