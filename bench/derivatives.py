#!/usr/bin/env python3
"""Per-instance energy derivatives: yasps kernels against JAX and PyTorch.

For each energy of bench/benchlib/energy_cases.py (inertia with gravity, mass-spring,
stable Neo-Hookean on positions, through F and on F, Baraff-Witkin cloth,
dihedral bending, the IPC barrier on point-point, point-edge,
point-triangle and edge-edge distances, ABD orthogonality, a pendulum in
angles), N independent instances (random non-degenerate elements) are
evaluated by yasps' compiled kernels (gradient + Hessian, and the
PSD-projected Hessian), by JAX (`jit(vmap(...))` of `grad` and `hessian` of
the same formula) and by PyTorch (`torch.func.vmap` of `torch.func.grad` and
`torch.func.hessian`, eager), all in float64 on one thread. Both peers' PSD
projection is a batched `eigh` and the clamped reconstruction. The script
first checks that every peer's gradient and Hessian agree with yasps'. Prints
time per instance and the ratios, plus yasps' symbolic differentiation +
kernel compile time and the Hessian kernel's multiplications and additions.

    python3 bench/derivatives.py [--count 20000] [--repeat 5] [--json PATH]

PyTorch is optional (`pip install torch`): without it the script says so
and prints the JAX columns only. SymPy-generated code is compared in
bench/sympy_compare.py.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import warnings
from functools import partial
from pathlib import Path
from typing import Callable, Optional, Tuple

# One thread for every peer.
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false "
                      "intra_op_parallelism_threads=1")
os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

from benchlib.energy_cases import CASES, ArrayOps, check_agrees  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.timing import median  # noqa: E402

try:
    import torch  # noqa: E402
    from torch.func import grad as torch_grad  # noqa: E402
    from torch.func import hessian as torch_hessian, vmap as torch_vmap  # noqa: E402
    from benchlib.energy_cases import TorchOps  # noqa: E402
    TORCH_SKIPPED: Optional[str] = None
except ImportError as err:  # PyTorch is optional
    torch = None
    TORCH_SKIPPED = f"{type(err).__name__}: {err}"

jax.config.update("jax_enable_x64", True)


def torch_times(tf: Callable, jargs: Tuple[np.ndarray, ...], check,
                repeat: int) -> Tuple[float, float]:
    """PyTorch's time for all instances of gradient + Hessian, and of
    gradient + PSD-projected Hessian (``eigh``, eigenvalues clamped at 0,
    rebuilt), one thread, after checking its derivatives against yasps'."""
    targs = [torch.from_numpy(np.ascontiguousarray(a)) for a in jargs]
    grad = torch_vmap(torch_grad(tf))
    hess = torch_vmap(torch_hessian(tf))

    def projected(*a: torch.Tensor) -> torch.Tensor:
        w, V = torch.linalg.eigh(hess(*a))
        return (V * w.clamp(min=0).unsqueeze(-2)) @ V.mT

    # Not under torch.no_grad(): there, torch.func.hessian of the
    # determinant silently returns wrong values (PyTorch 2.15).
    check_agrees(grad(*targs).numpy(), hess(*targs).numpy(), check)
    plain = median(lambda: (grad(*targs), hess(*targs)), repeat)
    proj = median(lambda: (grad(*targs), projected(*targs)), repeat)
    return plain, proj


#: The table's columns: (header, format in the JSON table, format printed).
#: Times are ns per instance, "compile" seconds, ratios peer / yasps.
JAX_COLUMNS = [
    ("energy", "", "{:34s}"),
    ("compile", "{:.2f}s", "{:7.2f}s"),
    ("yasps g+H", "{:.0f}ns", "{:10.0f}ns"),
    ("+proj", "{:.0f}ns", "{:8.0f}ns"),
    ("JAX g+H", "{:.0f}ns", "{:10.0f}ns"),
    ("JAX/yasps", "{:.1f}x", "{:10.1f}x"),
    ("JAX +proj", "{:.0f}ns", "{:9.0f}ns"),
    ("JAX/yasps", "{:.1f}x", "{:10.1f}x"),
]
TORCH_COLUMNS = [
    ("torch g+H", "{:.0f}ns", "{:10.0f}ns"),
    ("torch/yasps", "{:.1f}x", "{:12.1f}x"),
    ("torch +proj", "{:.0f}ns", "{:11.0f}ns"),
    ("torch/yasps", "{:.1f}x", "{:12.1f}x"),
]
#: The Hessian kernel's static multiplications and additions, printed as
#: one column "H mul/add".
COUNT_COLUMNS = [
    ("H mul", "{:d}", "{:7d}"),
    ("H add", "{:d}", "/{:d}"),
]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=5)
    add_json_argument(parser, "derivatives")
    args = parser.parse_args()
    n = args.count
    results = Results("derivatives")
    results.values.update(count=n, repeat=args.repeat,
                          torch_skipped=TORCH_SKIPPED)
    if torch is not None:
        torch.set_num_threads(1)
        # torch.func scripts its decompositions with the deprecated
        # torch.jit.script on first use; that is PyTorch's business.
        warnings.filterwarnings("ignore", message="`torch.jit.script` is deprecated",
                                category=FutureWarning)
    columns = JAX_COLUMNS + ([] if torch is None else TORCH_COLUMNS) + COUNT_COLUMNS
    title = f"{n} instances, one thread, median of {args.repeat}; times per instance"
    print(title)
    if TORCH_SKIPPED is not None:
        print(f"PyTorch skipped: torch is not importable ({TORCH_SKIPPED})")
    torch_header = "" if torch is None else (
        f"{'torch g+H':>12s}{'torch/yasps':>13s}{'torch +proj':>13s}{'torch/yasps':>13s}")
    print(f"{'energy':34s}{'compile':>8s}{'yasps g+H':>12s}{'+proj':>10s}"
          f"{'JAX g+H':>12s}{'JAX/yasps':>11s}{'JAX +proj':>11s}{'JAX/yasps':>11s}"
          f"{torch_header}{'H mul/add':>12s}")
    jax_ops = ArrayOps(jnp)
    torch_ops = None if torch is None else TorchOps()
    rows = []
    for case in CASES:
        jargs = case.instances(n)
        energy = case.build(jargs)
        compile_time, library, (grad_k, hess_k, proj_k) = \
            energy.kernels(["grad", "hess", "hess_proj"])
        check = energy.derivatives()
        grad_k(), hess_k(), proj_k()  # warm: output pages touched
        gh = median(lambda: (grad_k(), hess_k()), args.repeat)
        proj = median(proj_k, args.repeat)
        # yasps' projected kernel recomputes the Hessian: with the gradient
        # kernel it is the full "gradient + projected Hessian" cost.
        ours_proj = median(lambda: (grad_k(), proj_k()), args.repeat)

        f = partial(case.formula, jax_ops)
        grad = jax.jit(jax.vmap(jax.grad(f)))
        hess = jax.jit(jax.vmap(jax.hessian(f)))
        jx = [jnp.array(a) for a in jargs]
        check_agrees(np.array(grad(*jx)), np.array(hess(*jx)), check)
        jax_time = median(lambda: (grad(*jx).block_until_ready(),
                                   hess(*jx).block_until_ready()), args.repeat)

        @jax.jit
        def projected(*a):
            w, V = jnp.linalg.eigh(jax.vmap(jax.hessian(f))(*a))
            return jnp.einsum("nij,nj,nkj->nik", V, jnp.maximum(w, 0), V)
        projected(*jx).block_until_ready()
        jax_proj = median(lambda: (grad(*jx).block_until_ready(),
                                   projected(*jx).block_until_ready()), args.repeat)
        per = 1e9 / n
        counts = library.op_counts(energy.path("hess"))
        row = [case.name, compile_time, gh * per, proj * per,
               jax_time * per, jax_time / gh,
               jax_proj * per, jax_proj / ours_proj]
        if torch is not None:
            t_plain, t_proj = torch_times(partial(case.formula, torch_ops), jargs,
                                          check, args.repeat)
            row += [t_plain * per, t_plain / gh, t_proj * per, t_proj / ours_proj]
        row += [counts["mul"], counts["add"]]
        rows.append(row)
        print("".join(c[2].format(v) for c, v in zip(columns, row)), flush=True)
    note = (f"{title}. \"compile\": yasps' differentiation and kernel "
            "compilation, cold cache; ratios: peer / yasps; \"H mul\" and "
            "\"H add\": the Hessian kernel's operations after CSE.")
    if torch is None:
        note += f" PyTorch skipped: {TORCH_SKIPPED}."
    results.table("derivatives", [c[0] for c in columns], rows,
                  [c[1] for c in columns], note)
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
