#!/usr/bin/env python3
"""PyTorch and JAX on the stable Neo-Hookean instances of a GPU kit, for the
comparison with yasps' kernels timed by yasps-kernel-bench.

    yasps-kernel-bench KIT > kernels.log
    python3 bench/gpu_peers.py KIT [--yasps-log kernels.log] [--repeat 20]

Takes the formula's inputs from the kit (bench/gpu_kit.py's peer_inputs:
positions (N, 12) and inverse rest shapes (N, 9) of the bunny's tets),
evaluates the gradient
and Hessian of bench/benchlib/energy_cases.py's independent stable Neo-Hookean
formula with ``torch.func.vmap`` of ``grad`` / ``hessian`` and with JAX's
``jit(vmap(...))``, float64 on the default GPU, checks the first instances
against the CPU kernels' values in the kit, and prints the time of each for
all instances, with the ratios to yasps' times read from the kernel
benchmark's log. ``--device cpu`` checks the script without a GPU.
"""

from __future__ import annotations

import argparse
import re
from functools import partial
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
# energy_cases imports yasps, which loads its compiled extension only when
# it compiles: none is needed here.
import benchlib  # noqa: E402

benchlib.use_this_checkout()

from benchlib.energy_cases import ArrayOps, TorchOps, snh_positions  # noqa: E402
from benchlib.kit_files import peer_inputs  # noqa: E402
from benchlib.timing import per_call  # noqa: E402


#: The paper's RTX 4090 figures for the same work, ms, as the GPU issue
#: (7) quotes them (docs/benchmarks.md): ratios carry across GPUs, times
#: do not.
PAPER_RTX_4090 = {"grad": {"yasps": 0.197},
                  "hess": {"yasps": 0.59, "PyTorch": 216.9, "JAX": 10.7}}


def yasps_times(log: Path) -> dict:
    """{label: seconds} from yasps-kernel-bench's output."""
    times = {}
    for line in log.read_text().splitlines():
        match = re.match(r"\s+(\w+)\s+([0-9.]+) ms", line)
        if match:
            times[match.group(1)] = float(match.group(2)) * 1e-3
    return times


def check(label: str, got: np.ndarray, kit: Path, name: str) -> None:
    want = np.load(kit / f"{name}_reference.npy")
    got = got.reshape(-1)[:want.size]
    error = np.abs(got - want).max() / np.abs(want).max()
    assert error < 1e-7, f"{label}: {name} off by {error:.2e}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("kit", type=Path)
    parser.add_argument("--yasps-log", type=Path, default=None)
    parser.add_argument("--repeat", type=int, default=20)
    parser.add_argument("--device", default="cuda")
    args = parser.parse_args()
    arrays = list(peer_inputs(args.kit))
    ours = yasps_times(args.yasps_log) if args.yasps_log else {}
    results = {}

    import torch
    from torch.func import grad, hessian, vmap
    device = torch.device(args.device)
    targs = [torch.from_numpy(a).to(device) for a in arrays]
    f = partial(snh_positions, TorchOps())
    finish = (lambda _: torch.cuda.synchronize()) if device.type == "cuda" \
        else (lambda _: None)
    for name, fn, repeat in (("grad", vmap(grad(f)), args.repeat),
                             ("hess", vmap(hessian(f)),
                              max(args.repeat // 5, 2))):
        check("PyTorch", fn(*targs).cpu().numpy(), args.kit, name)
        results[("PyTorch", name)] = per_call(lambda: fn(*targs), repeat,
                                              finish)

    import jax
    import jax.numpy as jnp
    jax.config.update("jax_enable_x64", True)
    jdevice = jax.devices("gpu" if args.device == "cuda" else "cpu")[0]
    jargs = [jax.device_put(a, jdevice) for a in arrays]
    jf = partial(snh_positions, ArrayOps(jnp))
    for name, fn in (("grad", jax.jit(jax.vmap(jax.grad(jf)))),
                     ("hess", jax.jit(jax.vmap(jax.hessian(jf))))):
        check("JAX", np.asarray(fn(*jargs)), args.kit, name)
        results[("JAX", name)] = per_call(lambda: fn(*jargs), args.repeat,
                                          lambda r: r.block_until_ready())

    where = torch.cuda.get_device_name() if device.type == "cuda" else "CPU"
    print(f"stable Neo-Hookean on positions, {len(arrays[0])} bunny tets, "
          f"float64, {where}: ms for all instances")
    for name in ("grad", "hess"):
        row = [f"  {name:6s}"]
        if name in ours:
            row.append(f"yasps {ours[name] * 1e3:8.3f}")
        for peer in ("PyTorch", "JAX"):
            t = results[(peer, name)]
            ratio = f" ({t / ours[name]:.0f}x)" if name in ours else ""
            row.append(f"{peer} {t * 1e3:9.3f}{ratio}")
        print("   ".join(row))
    print("the paper's RTX 4090 (ms; the ratios are what compare):")
    for name, paper in PAPER_RTX_4090.items():
        row = [f"  {name:6s}", f"yasps {paper['yasps']:8.3f}"]
        for peer in ("PyTorch", "JAX"):
            if peer in paper:
                row.append(f"{peer} {paper[peer]:9.3f} "
                           f"({paper[peer] / paper['yasps']:.0f}x)")
        print("   ".join(row))


if __name__ == "__main__":
    main()
