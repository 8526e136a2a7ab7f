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

    python3 bench/gpu.py [spmv] [derivatives] [newton] [--repeat 50] [--json PATH]

Each part run writes its table (``spmv``, ``derivatives``, ``newton``) to the
JSON results.
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
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.timing import median, per_call  # noqa: E402


def spmv(repeat: int, results: Results) -> None:
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
    peers = {}
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
            peers[name] = per_call(lambda: matrix @ xt, repeat,
                                   lambda _: sync())
        except (RuntimeError, NotImplementedError) as err:
            peers[name] = f"not run: {type(err).__name__}: {err}"

    # Achievable bandwidth: a device-to-device copy of 1 GiB (read + write).
    src = torch.empty(1 << 27, dtype=torch.float64, device=cuda)
    dst = torch.empty_like(src)
    copy = per_call(lambda: dst.copy_(src), 20, lambda _: sync())
    bandwidth = 2 * src.numel() * 8 / copy
    bound = system.multiply_bytes / bandwidth

    title = (f"SpMV, bunny-19k Hessian ({n} DoFs, {system.stored_blocks} "
             f"stored upper blocks, {nnz} scalar non-zeros), "
             f"{torch.cuda.get_device_name()}")
    bound_line = (f"bandwidth bound: {system.multiply_bytes / 2**20:.1f} MiB at "
                  f"{bandwidth / 1e9:.0f} GB/s (device copy) = "
                  f"{bound * 1e3:.4f} ms; yasps reaches {100 * bound / ours:.0f}%")
    # ms, and the time against yasps'; a peer that could not run has none.
    rows = [["yasps (upper triangle, algorithm 7)", ours * 1e3, 1.0]]
    not_run = []
    for name, t in peers.items():
        if isinstance(t, str):
            rows.append([name, None, None])
            not_run.append(f"{name}: {t}.")
        else:
            rows.append([name, t * 1e3, t / ours])
    rows.append(["bandwidth bound (device copy speed)", bound * 1e3,
                 bound / ours])
    results.values["spmv"] = dict(
        dofs=n, stored_blocks=system.stored_blocks, non_zeros=nnz,
        device=torch.cuda.get_device_name(),
        multiply_bytes=system.multiply_bytes, bandwidth=bandwidth,
        bound_fraction=bound / ours)
    results.table("spmv", ["SpMV", "time", "against yasps"], rows,
                  ["", "{:.4f} ms", "{:.2f}x yasps"],
                  " ".join([f"{title}. {bound_line}."] + not_run))

    print(title)
    print(f"  {rows[0][0]}  {rows[0][1]:8.4f} ms")
    for name, t in peers.items():
        if isinstance(t, str):
            print(f"  {name:36s} {t}")
        else:
            print(f"  {name:36s} {t * 1e3:8.4f} ms  ({t / ours:.2f}x yasps)")
    print(f"  {bound_line}")


def derivatives(repeat: int, results: Results) -> None:
    import jax
    import jax.numpy as jnp
    import torch
    from torch.func import grad as torch_grad, hessian as torch_hessian, \
        vmap as torch_vmap

    from benchlib.energy_cases import CASES, ArrayOps, TorchOps, snh_positions
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

    title = (f"stable Neo-Hookean on positions, {count} bunny tets, float64, "
             f"{torch.cuda.get_device_name()} (ms for all instances)")
    rows = []
    for name in names:
        y, t, j = yasps_seconds[name], torch_seconds[name], jax_seconds[name]
        rows.append([name, y * 1e3, t * 1e3, j * 1e3, t / y, j / y])
    results.table("derivatives", ["", "yasps", "PyTorch", "JAX",
                                  "PyTorch/yasps", "JAX/yasps"], rows,
                  ["", "{:.3f} ms", "{:.3f} ms", "{:.3f} ms", "{:.0f}x",
                   "{:.1f}x"], f"{title[0].upper()}{title[1:]}.")
    print(title)
    print(f"  {'':10s}{'yasps':>10s}{'PyTorch':>12s}{'JAX':>10s}")
    for name, y, t, j, t_ratio, j_ratio in rows:
        print(f"  {name:10s}{y:10.3f}{t:12.3f}{j:10.3f}   "
              f"PyTorch {t_ratio:.0f}x, JAX {j_ratio:.1f}x yasps")


def newton(results: Results) -> None:
    s = bunny_snh()
    title = ("one Newton iteration, bunny-19k, stable Neo-Hookean + inertia "
             "(second call: static structure reused)")
    print(title)
    runs = {}
    for where in ("cpu", "gpu"):
        yasps.config.backend = where
        s.minimizeEnergy(tolerance=1e-4)   # compiles, builds the structure
        s.minimizeEnergy(tolerance=1e-4)
        runs[where] = dict(s.lastSolve["seconds"],
                           iterations=s.lastSolve["iterations"])
    # ms per stage on each backend, and CPU / GPU.
    rows = []
    for stage in ("derivatives", "indices", "assembly", "solve"):
        c, g = runs["cpu"][stage], runs["gpu"][stage]
        rows.append([stage, c * 1e3, g * 1e3, c / g])
    iterations = (f"PCG iterations: CPU {runs['cpu']['iterations']}, "
                  f"GPU {runs['gpu']['iterations']}")
    results.values["newton"] = runs
    results.table("newton", ["stage", "CPU (all cores)", "GPU", "speed-up"],
                  rows, ["", "{:.1f} ms", "{:.1f} ms", "{:.1f}x"],
                  f"{title[0].upper()}{title[1:]}. {iterations}.")
    print(f"  {'stage':12s}{'CPU (all cores)':>16s}{'GPU':>10s}")
    for stage, c, g, ratio in rows:
        print(f"  {stage:12s}{c:13.1f} ms{g:7.1f} ms   ({ratio:.1f}x)")
    print(f"  {iterations}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("parts", nargs="*",
                        default=["spmv", "derivatives", "newton"])
    parser.add_argument("--repeat", type=int, default=50)
    add_json_argument(parser, "gpu")
    args = parser.parse_args()
    parts = {"spmv": lambda: spmv(args.repeat, results),
             "derivatives": lambda: derivatives(args.repeat, results),
             "newton": lambda: newton(results)}
    unknown = [p for p in args.parts if p not in parts]
    if unknown:
        parser.error(f"unknown parts {unknown}: choose from {list(parts)}")
    status = yasps.gpu_status()
    if not status.usable:
        sys.exit(f"bench/gpu.py needs a GPU: {status.reason}")
    results = Results("gpu")
    results.values["repeat"] = args.repeat
    for part in args.parts:
        parts[part]()
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
