#!/usr/bin/env python3
"""The GPU backend on the bunny: SpMV, per-instance derivatives, a Newton
iteration. Needs a CUDA GPU; each part is checked before it is timed.

1. ``spmv``: the runtime's SpMV (upper triangle, a kernel per block shape,
   the paper's algorithm 7) on the assembled bunny-19k Hessian (stable
   Neo-Hookean + inertia, as bench/newton_system.py), against cuSPARSE's
   BSR and CSR SpMV (through PyTorch) on the same matrix stored whole, and
   against the memory-bandwidth bound: the bytes the runtime's SpMV must
   move at least (values, block coordinates, x and y once) at the
   bandwidth of a device-to-device copy.
2. ``derivatives``: per-instance gradient and Hessian of stable Neo-Hookean
   on positions over the 79,935 bunny tets: yasps' generated CUDA kernels
   against PyTorch (``torch.func.vmap`` of ``grad`` / ``hessian``) and JAX
   (``jit(vmap(...))``) on the same GPU, float64, after checking that all
   three agree with the CPU kernels.
3. ``newton``: one ``minimizeEnergy`` of bench/benchlib/elastic_scenes.py's bunny_snh scene on
   the GPU backend (derivatives, indices, assembly, PCG), split into stages,
   against the CPU backend.

    python3 bench/gpu.py [spmv] [derivatives] [newton] [--repeat 50]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from functools import partial
from pathlib import Path

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))
HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

import numpy as np  # noqa: E402

import yasps  # noqa: E402
from yasps.compiler.pipelines import DIFFERENTIATION_PIPELINE  # noqa: E402
from yasps.ir import emit_scene  # noqa: E402
from yasps.runtime import cpu_backend, gpu_backend  # noqa: E402
from yasps.solve import assemble  # noqa: E402

from benchlib.elastic_scenes import bunny_snh, bunny_snh_inputs  # noqa: E402
from benchlib.timing import median, per_call  # noqa: E402


def spmv(repeat: int) -> None:
    import torch
    import scipy.sparse as sparse

    s = bunny_snh()
    system = assemble(s, gpu_backend()).system
    host = assemble(s, cpu_backend()).system
    n = system.size
    x = np.random.default_rng(1).normal(size=n)
    want, got = np.empty(n), np.empty(n)
    host.multiply(x, want, 0)
    system.multiply(x, got)
    np.testing.assert_allclose(got, want, rtol=1e-10,
                               atol=1e-10 * np.abs(want).max())
    ours = system.time_multiply(repeat)

    nnz = host.non_zeros
    rows, cols, values = np.empty(nnz, np.int64), np.empty(nnz, np.int64), \
        np.empty(nnz)
    host.coordinates(rows, cols, values)
    csr = sparse.csr_matrix((values, (rows, cols)), shape=(n, n))
    bsr = csr.tobsr(blocksize=(3, 3))
    cuda = torch.device("cuda")
    xt = torch.from_numpy(x).to(cuda)
    sync = torch.cuda.synchronize
    results = {}
    for name, matrix in (
            ("cuSPARSE BSR 3x3 (whole matrix)", torch.sparse_bsr_tensor(
                torch.from_numpy(bsr.indptr), torch.from_numpy(bsr.indices),
                torch.from_numpy(bsr.data), size=(n, n)).to(cuda)),
            ("cuSPARSE CSR (whole matrix)", torch.sparse_csr_tensor(
                torch.from_numpy(csr.indptr), torch.from_numpy(csr.indices),
                torch.from_numpy(csr.data), size=(n, n)).to(cuda))):
        try:
            y = (matrix @ xt).cpu().numpy()
            np.testing.assert_allclose(y, want, rtol=1e-10,
                                       atol=1e-10 * np.abs(want).max())
            results[name] = per_call(lambda: matrix @ xt, repeat,
                                     lambda _: sync())
        except (RuntimeError, NotImplementedError) as err:
            results[name] = f"not run: {type(err).__name__}: {err}"

    # Achievable bandwidth: a device-to-device copy of 1 GiB (read + write).
    src = torch.empty(1 << 27, dtype=torch.float64, device=cuda)
    dst = torch.empty_like(src)
    copy = per_call(lambda: dst.copy_(src), 20, lambda _: sync())
    bandwidth = 2 * src.numel() * 8 / copy
    bound = system.multiply_bytes / bandwidth

    print(f"SpMV, bunny-19k Hessian ({n} DoFs, {system.stored_blocks} stored "
          f"upper blocks, {nnz} scalar non-zeros), {torch.cuda.get_device_name()}")
    print(f"  yasps (upper triangle, algorithm 7)  {ours * 1e3:8.4f} ms")
    for name, t in results.items():
        if isinstance(t, str):
            print(f"  {name:36s} {t}")
        else:
            print(f"  {name:36s} {t * 1e3:8.4f} ms  ({t / ours:.2f}x yasps)")
    print(f"  bandwidth bound: {system.multiply_bytes / 2**20:.1f} MiB at "
          f"{bandwidth / 1e9:.0f} GB/s (device copy) = {bound * 1e3:.4f} ms; "
          f"yasps reaches {100 * bound / ours:.0f}%")


def derivatives(repeat: int) -> None:
    import jax
    import jax.numpy as jnp
    import torch
    from torch.func import grad as torch_grad, hessian as torch_hessian, \
        vmap as torch_vmap

    from energy_cases import CASES, ArrayOps, TorchOps, snh_positions
    from yasps.runtime.gpu import session

    jax.config.update("jax_enable_x64", True)
    arrays = bunny_snh_inputs()
    count = len(arrays[0])
    case = next(c for c in CASES if c.name == "stable Neo-Hookean (x, 12)")
    energy = case.build(arrays)
    check = energy.derivatives()   # CPU kernels, the reference

    gpu = session()
    names = ("grad", "hess")
    paths = [energy.path(k) for k in names]
    kernels = gpu.kernels(emit_scene(energy.scene), paths, energy.scene.name,
                          DIFFERENTIATION_PIPELINE)
    sync = gpu.device.synchronize
    yasps_seconds = {}
    for name, path in zip(names, paths):
        k = kernels.kernel(path)
        size = count * k.rows * k.cols
        # One output buffer, reused by every timed call.
        run = partial(gpu_backend().run, kernels, energy.scene, path, count,
                      None, ("bench", path))
        out = run()
        host = np.empty(size)
        out.download(host)
        want = check.gradient if name == "grad" else check.hessian
        np.testing.assert_allclose(host.reshape(want.shape), want, rtol=1e-10,
                                   atol=1e-10 * np.abs(want).max())
        yasps_seconds[name] = per_call(run, repeat, lambda _: sync())

    cuda = torch.device("cuda")
    targs = [torch.from_numpy(np.ascontiguousarray(a)).to(cuda) for a in arrays]
    tf = partial(snh_positions, TorchOps())
    tgrad, thess = torch_vmap(torch_grad(tf)), torch_vmap(torch_hessian(tf))
    np.testing.assert_allclose(thess(*targs).cpu().numpy(), check.hessian,
                               rtol=1e-7, atol=1e-7 * np.abs(check.hessian).max())
    torch_sync = lambda _: torch.cuda.synchronize()  # noqa: E731
    torch_seconds = {
        "grad": per_call(lambda: tgrad(*targs), repeat, torch_sync),
        "hess": per_call(lambda: thess(*targs), max(repeat // 10, 3),
                         torch_sync)}

    jf = partial(snh_positions, ArrayOps(jnp))
    jgrad, jhess = jax.jit(jax.vmap(jax.grad(jf))), \
        jax.jit(jax.vmap(jax.hessian(jf)))
    jargs = [jax.device_put(a) for a in arrays]
    np.testing.assert_allclose(np.asarray(jhess(*jargs)), check.hessian,
                               rtol=1e-7, atol=1e-7 * np.abs(check.hessian).max())
    jax_seconds = {}
    for name, fn in (("grad", jgrad), ("hess", jhess)):
        jax_seconds[name] = median(lambda: fn(*jargs).block_until_ready(),
                                   repeat)

    print(f"stable Neo-Hookean on positions, {count} bunny tets, float64, "
          f"{torch.cuda.get_device_name()} (ms for all instances)")
    print(f"  {'':10s}{'yasps':>10s}{'PyTorch':>12s}{'JAX':>10s}")
    for name in names:
        y, t, j = yasps_seconds[name], torch_seconds[name], jax_seconds[name]
        print(f"  {name:10s}{y * 1e3:10.3f}{t * 1e3:12.3f}{j * 1e3:10.3f}   "
              f"PyTorch {t / y:.0f}x, JAX {j / y:.1f}x yasps")


def newton() -> None:
    s = bunny_snh()
    print("one Newton iteration, bunny-19k, stable Neo-Hookean + inertia "
          "(second call: static structure reused)")
    rows = {}
    for where in ("cpu", "gpu"):
        yasps.config.backend = where
        s.minimizeEnergy(tolerance=1e-4)   # compiles, builds the structure
        s.minimizeEnergy(tolerance=1e-4)
        rows[where] = dict(s.lastSolve["seconds"],
                           iterations=s.lastSolve["iterations"])
    print(f"  {'stage':12s}{'CPU (all cores)':>16s}{'GPU':>10s}")
    for stage in ("derivatives", "indices", "assembly", "solve"):
        c, g = rows["cpu"][stage], rows["gpu"][stage]
        print(f"  {stage:12s}{c * 1e3:13.1f} ms{g * 1e3:7.1f} ms   "
              f"({c / g:.1f}x)")
    print(f"  PCG iterations: CPU {rows['cpu']['iterations']}, "
          f"GPU {rows['gpu']['iterations']}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("parts", nargs="*",
                        default=["spmv", "derivatives", "newton"])
    parser.add_argument("--repeat", type=int, default=50)
    args = parser.parse_args()
    status = yasps.gpu_status()
    if not status.usable:
        sys.exit(f"bench/gpu.py needs a GPU: {status.reason}")
    for part in args.parts:
        {"spmv": lambda: spmv(args.repeat),
         "derivatives": lambda: derivatives(args.repeat),
         "newton": newton}[part]()


if __name__ == "__main__":
    main()
