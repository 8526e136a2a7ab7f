#!/usr/bin/env python3
"""Per-instance energy derivatives: yasps kernels against JAX, one thread.

For each energy, N independent instances (random non-degenerate elements)
are evaluated by yasps' compiled kernels (value + gradient + Hessian, and the
PSD-projected Hessian) and by JAX (`jit(vmap(...))` of `grad` and `hessian`
of the same formula, float64). Prints time per instance and the ratio, plus
yasps' symbolic differentiation + kernel compile time.

    python3 bench/derivatives.py [--count 20000] [--repeat 5]

SymPy and PyTorch are not part of this run (see docs/benchmarks.md).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

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
    return s, e, x, energy, f, (cur.reshape(count, -1), dm_inv)


def snh_via_F(count):
    """The paper's section 10.4 trick: F as its own attribute, JOINed by a
    one-to-one primitive, so the projection is 9x9 in reduced space."""
    s, e, x, energy, f, jargs = snh_positions(count)
    m = s.m
    e.addAttribute("F", computed_attribute=E.deformation_gradient(e["c"], e["inv"]))
    fe = m.addPrimitive("fe", numInstances=count)
    fe2t = fe.addConnectivity("fe2t", e, np.arange(count), 1)
    jf = fe.addAttribute("F", through=fe2t, source=e["F"])
    return s, fe, x, E.stable_neo_hookean(jf.resize(3, 3), MU, LAM, 1.0), f, jargs


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
    return s, e, F, energy, f, (np.transpose(Fv, (0, 2, 1)).reshape(count, 9),)


def spring(count):
    ends = rng.normal(size=(count, 2, 3))
    s, e, x, c = elements(count, 2, ends)
    energy = E.mass_spring(c, 1.0, 3.0)

    def f(flat):
        p = flat.reshape(2, 3)
        return 0.5 * 3.0 * (jnp.linalg.norm(p[1] - p[0]) - 1.0) ** 2
    return s, e, x, energy, f, (ends.reshape(count, -1),)


def barrier_pp(count):
    pts = rng.normal(scale=0.01, size=(count, 2, 3))
    s, e, x, c = elements(count, 2, pts)
    dhat = 1.0
    energy = E.ipc_barrier(E.point_point_distance2(c.row(0), c.row(1)), dhat, 1e3)

    def f(flat):
        p = flat.reshape(2, 3)
        d = jnp.sum((p[1] - p[0]) ** 2)
        return jnp.where(d < dhat, 1e3 * (d - dhat) ** 2 * jnp.log(d / dhat) ** 2, 0.0)
    return s, e, x, energy, f, (pts.reshape(count, -1),)


ENERGIES = {
    "stable Neo-Hookean (x, 12)": snh_positions,
    "stable Neo-Hookean (x via F, 12)": snh_via_F,
    "stable Neo-Hookean (F, 9)": snh_F,
    "mass-spring (6)": spring,
    "IPC barrier PP (6)": barrier_pp,
}




def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    n = args.count
    print(f"{n} instances, one thread, median of {args.repeat}; times per instance")
    print(f"{'energy':30s}{'compile':>10s}{'yasps g+H':>12s}{'+proj':>10s}"
          f"{'JAX g+H':>12s}{'JAX/yasps':>11s}{'JAX +proj':>11s}{'JAX/yasps':>11s}"
          f"{'H mul/add':>12s}")
    for name, make in ENERGIES.items():
        s, owner, target, energy, f, jargs = make(n)
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
        g_ref = np.array(grad(*jx))
        h_ref = np.array(hess(*jx))
        np.testing.assert_allclose(check.gradient, g_ref, rtol=1e-8, atol=1e-8)
        np.testing.assert_allclose(check.hessian, h_ref, rtol=1e-7,
                                   atol=1e-7 * np.abs(h_ref).max())
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
        print(f"{name:30s}{compile_time:9.2f}s{gh * per:10.0f}ns{proj * per:8.0f}ns"
              f"{jax_time * per:10.0f}ns{jax_time / gh:10.1f}x"
              f"{jax_proj * per:9.0f}ns{jax_proj / ours_proj:10.1f}x"
              f"{counts['mul']:7d}/{counts['add']:<5d}")


if __name__ == "__main__":
    main()
