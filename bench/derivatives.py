#!/usr/bin/env python3
"""Per-instance energy derivatives: yasps kernels against JAX and PyTorch.

For each energy, N independent instances (random non-degenerate elements)
are evaluated by yasps' compiled kernels (value + gradient + Hessian, and the
PSD-projected Hessian), by JAX (`jit(vmap(...))` of `grad` and `hessian` of
the same formula) and by PyTorch (`torch.func.vmap` of `torch.func.grad` and
`torch.func.hessian`, eager), all in float64 on one thread. Both peers' PSD
projection is a batched `eigh` and the clamped reconstruction. The script
first checks that every peer's gradient and Hessian agree with yasps'. Prints
time per instance and the ratios, plus yasps' symbolic differentiation +
kernel compile time.

    python3 bench/derivatives.py [--count 20000] [--repeat 5]

PyTorch is optional (`pip install torch`): without it the script says so
and prints the JAX columns only. SymPy-generated code is compared in
bench/sympy_compare.py.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Callable, Optional, Tuple

# One thread for every peer.
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false "
                      "intra_op_parallelism_threads=1")
os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "python"))

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402

import yasps  # noqa: E402
from timing import median  # noqa: E402
from yasps import energies as E  # noqa: E402
from yasps.evaluate import _buffer, _compile, DIFFERENTIATION_PIPELINE  # noqa: E402
from yasps.emit import emit_scene  # noqa: E402

try:
    import torch  # noqa: E402
    from torch.func import grad as torch_grad  # noqa: E402
    from torch.func import hessian as torch_hessian, vmap as torch_vmap  # noqa: E402
    TORCH_SKIPPED: Optional[str] = None
except ImportError as err:  # PyTorch is optional
    torch = None
    TORCH_SKIPPED = f"{type(err).__name__}: {err}"

jax.config.update("jax_enable_x64", True)
rng = np.random.default_rng(0)
MU, LAM = 1.0, 10.0


def elements(count, arity, values):
    s = yasps.scene("bench")
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=count * arity)
    e = m.addPrimitive("e", numInstances=count)
    x = v.addAttribute("x", rows=3, cols=1)
    x.updateValue(values.reshape(-1, 3))
    conn = e.addConnectivity("e2v", v, np.arange(count * arity).reshape(count, arity), arity)
    return s, e, x, e.addAttribute("c", through=conn, source=x)


def snh_positions(count):
    base = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    rest = base[None] + rng.normal(scale=0.05, size=(count, 4, 3))
    cur = rest @ (np.eye(3) + rng.normal(scale=0.2, size=(count, 3, 3)))
    dm_inv = np.linalg.inv(np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2))
    s, e, x, c = elements(count, 4, cur)
    inv = e.addConstant("inv", rows=3, cols=3)
    inv.updateValue(dm_inv)
    energy = E.stable_neo_hookean(E.deformation_gradient(c, inv), MU, LAM, 1.0)

    def f(flat, dinv):
        p = flat.reshape(4, 3)
        F = jnp.stack([p[k] - p[0] for k in (1, 2, 3)], axis=1) @ dinv
        ic = jnp.sum(F * F)
        J = jnp.linalg.det(F)
        return 0.5 * MU * (ic - 3) - 0.5 * MU * jnp.log(ic + 1) + \
            0.5 * LAM * (J - 1 - 0.75 * MU / LAM) ** 2

    def tf(flat, dinv):
        p = flat.reshape(4, 3)
        F = torch.stack([p[k] - p[0] for k in (1, 2, 3)], dim=1) @ dinv
        ic = torch.sum(F * F)
        J = torch.linalg.det(F)
        return 0.5 * MU * (ic - 3) - 0.5 * MU * torch.log(ic + 1) + \
            0.5 * LAM * (J - 1 - 0.75 * MU / LAM) ** 2
    return s, e, x, energy, f, tf, (cur.reshape(count, -1), dm_inv)


def snh_via_F(count):
    """The paper's section 10.4 trick: F as its own attribute, JOINed by a
    one-to-one primitive, so the projection is 9x9 in reduced space."""
    s, e, x, energy, f, tf, jargs = snh_positions(count)
    m = s.m
    e.addAttribute("F", computed_attribute=E.deformation_gradient(e["c"], e["inv"]))
    fe = m.addPrimitive("fe", numInstances=count)
    fe2t = fe.addConnectivity("fe2t", e, np.arange(count), 1)
    jf = fe.addAttribute("F", through=fe2t, source=e["F"])
    return s, fe, x, E.stable_neo_hookean(jf.resize(3, 3), MU, LAM, 1.0), f, tf, jargs


def snh_F(count):
    s = yasps.scene("bench")
    e = s.addMesh("m").addPrimitive("e", numInstances=count)
    F = e.addAttribute("F", rows=3, cols=3)
    Fv = np.eye(3) + rng.normal(scale=0.2, size=(count, 3, 3))
    F.updateValue(Fv)
    energy = E.stable_neo_hookean(F, MU, LAM, 1.0)

    def f(flat):
        G = flat.reshape(3, 3).T  # column-major parameters
        ic = jnp.sum(G * G)
        J = jnp.linalg.det(G)
        return 0.5 * MU * (ic - 3) - 0.5 * MU * jnp.log(ic + 1) + \
            0.5 * LAM * (J - 1 - 0.75 * MU / LAM) ** 2

    def tf(flat):
        G = flat.reshape(3, 3).T  # column-major parameters
        ic = torch.sum(G * G)
        J = torch.linalg.det(G)
        return 0.5 * MU * (ic - 3) - 0.5 * MU * torch.log(ic + 1) + \
            0.5 * LAM * (J - 1 - 0.75 * MU / LAM) ** 2
    return s, e, F, energy, f, tf, (np.transpose(Fv, (0, 2, 1)).reshape(count, 9),)


def spring(count):
    ends = rng.normal(size=(count, 2, 3))
    s, e, x, c = elements(count, 2, ends)
    energy = E.mass_spring(c, 1.0, 3.0)

    def f(flat):
        p = flat.reshape(2, 3)
        return 0.5 * 3.0 * (jnp.linalg.norm(p[1] - p[0]) - 1.0) ** 2

    def tf(flat):
        p = flat.reshape(2, 3)
        return 0.5 * 3.0 * (torch.linalg.norm(p[1] - p[0]) - 1.0) ** 2
    return s, e, x, energy, f, tf, (ends.reshape(count, -1),)


def barrier_pp(count):
    pts = rng.normal(scale=0.01, size=(count, 2, 3))
    s, e, x, c = elements(count, 2, pts)
    dhat = 1.0
    energy = E.ipc_barrier(E.point_point_distance2(c.row(0), c.row(1)), dhat, 1e3)

    def f(flat):
        p = flat.reshape(2, 3)
        d = jnp.sum((p[1] - p[0]) ** 2)
        return jnp.where(d < dhat, 1e3 * (d - dhat) ** 2 * jnp.log(d / dhat) ** 2, 0.0)

    def tf(flat):
        p = flat.reshape(2, 3)
        d = torch.sum((p[1] - p[0]) ** 2)
        return torch.where(d < dhat, 1e3 * (d - dhat) ** 2 * torch.log(d / dhat) ** 2,
                           torch.zeros_like(d))
    return s, e, x, energy, f, tf, (pts.reshape(count, -1),)


# Each builder returns the scene, the energy's owner, the minimisation target,
# the energy, the same formula for JAX (f) and for PyTorch (tf), and their
# per-instance arguments (parameters first).
ENERGIES = {
    "stable Neo-Hookean (x, 12)": snh_positions,
    "stable Neo-Hookean (x via F, 12)": snh_via_F,
    "stable Neo-Hookean (F, 9)": snh_F,
    "mass-spring (6)": spring,
    "IPC barrier PP (6)": barrier_pp,
}


def check_agrees(gradient: np.ndarray, hessian: np.ndarray, check) -> None:
    """Asserts that a peer's per-instance gradient (N, n) and Hessian
    (N, n, n) agree with yasps' local derivatives ``check``."""
    np.testing.assert_allclose(check.gradient, gradient, rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(check.hessian, hessian, rtol=1e-7,
                               atol=1e-7 * np.abs(hessian).max())


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    n = args.count
    if torch is not None:
        torch.set_num_threads(1)
        # torch.func scripts its decompositions with the deprecated
        # torch.jit.script on first use; that is PyTorch's business.
        warnings.filterwarnings("ignore", message="`torch.jit.script` is deprecated",
                                category=FutureWarning)
    print(f"{n} instances, one thread, median of {args.repeat}; times per instance")
    if TORCH_SKIPPED is not None:
        print(f"PyTorch skipped: torch is not importable ({TORCH_SKIPPED})")
    torch_header = "" if torch is None else (
        f"{'torch g+H':>12s}{'torch/yasps':>13s}{'torch +proj':>13s}{'torch/yasps':>13s}")
    print(f"{'energy':34s}{'compile':>8s}{'yasps g+H':>12s}{'+proj':>10s}"
          f"{'JAX g+H':>12s}{'JAX/yasps':>11s}{'JAX +proj':>11s}{'JAX/yasps':>11s}"
          f"{torch_header}{'H mul/add':>12s}")
    for name, make in ENERGIES.items():
        s, owner, target, energy, f, tf, jargs = make(n)
        attr = owner.addAttribute("energy", computed_attribute=energy)
        s.addEnergy(attr)
        s.addMinimizeTarget([target])
        base = "::".join("@" + p for p in owner.path + ["energy"])
        paths = [base + "__grad", base + "__hess", base + "__hess_proj"]
        t0 = time.perf_counter()
        library, _ = _compile(emit_scene(s), paths, s, DIFFERENTIATION_PIPELINE)
        compile_time = time.perf_counter() - t0
        check = s.energyDerivatives(attr, threads=1)
        d = check.gradient.shape[1]
        launches = []
        for path, size in zip(paths, [n * d, n * d * d, n * d * d]):
            arguments = dict(library.kernels)[path]
            out = np.empty(size)
            buffers = [_buffer(s, k, p, out) for k, p in arguments]
            launches.append(lambda path=path, b=buffers: library.launch(path, n, b, 1))
        gh = median(lambda: (launches[0](), launches[1]()), args.repeat)
        proj = median(launches[2], args.repeat)

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
        counts = library.op_counts(paths[1])
        # yasps' projected kernel recomputes the Hessian: with the gradient
        # kernel it is the full "gradient + projected Hessian" cost.
        ours_proj = median(
            lambda: (launches[0](), launches[2]()), args.repeat)
        torch_cols = ""
        if torch is not None:
            t_plain, t_proj = torch_times(tf, jargs, check, args.repeat)
            torch_cols = (f"{t_plain * per:10.0f}ns{t_plain / gh:12.1f}x"
                          f"{t_proj * per:11.0f}ns{t_proj / ours_proj:12.1f}x")
        print(f"{name:34s}{compile_time:7.2f}s{gh * per:10.0f}ns{proj * per:8.0f}ns"
              f"{jax_time * per:10.0f}ns{jax_time / gh:10.1f}x"
              f"{jax_proj * per:9.0f}ns{jax_proj / ours_proj:10.1f}x"
              f"{torch_cols}{counts['mul']:7d}/{counts['add']}")


if __name__ == "__main__":
    main()
