#!/usr/bin/env python3
"""PyTorch and JAX on the stable Neo-Hookean instances of a GPU kit, for the
comparison with yasps' kernels timed by yasps-kernel-bench.

    yasps-kernel-bench KIT > kernels.log
    python3 bench/gpu_peers.py KIT [--yasps-log kernels.log] [--repeat 20] [--json PATH]

Takes the formula's inputs from the kit (bench/gpu_kit.py's peer_inputs:
positions (N, 12) and inverse rest shapes (N, 9) of the bunny's tets),
evaluates the gradient
and Hessian of bench/benchlib/energy_cases.py's independent stable Neo-Hookean
formula with ``torch.func.vmap`` of ``grad`` / ``hessian`` and with JAX's
``jit(vmap(...))``, float64 on the default GPU, checks the first instances
against the CPU kernels' values in the kit, and prints the time of each for
all instances, with the ratios to yasps' times read from the kernel
benchmark's log (and yasps' projected Hessian alone, where the log has
it). ``--device cpu`` checks the script without a GPU.
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
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.timing import per_call  # noqa: E402


#: The paper's RTX 4090 figures for the same work, ms, as the GPU issue
#: (7) quotes them (docs/benchmarks.md): ratios carry across GPUs, times
#: do not.
PAPER_RTX_4090 = {"grad": {"yasps": 0.197},
                  "hess": {"yasps": 0.59, "PyTorch": 216.9, "JAX": 10.7}}

#: The kernels' labels (in yasps-kernel-bench's log) and their rows in the
#: tables.
ROWS = {"grad": "gradient", "hess": "Hessian", "hess_proj": "projected Hessian"}
#: The tables' columns (after the first, which names the work) and formats.
COLUMNS = ["yasps", "PyTorch (vmap)", "PyTorch vs yasps", "JAX (jit vmap)",
           "JAX vs yasps"]
FORMATS = ["", "{:.3f} ms", "{:.3f} ms", "{:.0f}x", "{:.3f} ms", "{:.0f}x"]


def row(name: str, ms: dict) -> list:
    """A table row of ``ms`` ({system: ms}, any missing): the times and
    each peer's ratio to yasps'."""
    y = ms.get("yasps")
    cells = [ROWS[name], y]
    for peer in ("PyTorch", "JAX"):
        t = ms.get(peer)
        cells += [t, t / y if t is not None and y is not None else None]
    return cells


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
    add_json_argument(parser, "gpu_peers")
    args = parser.parse_args()
    out = Results("gpu_peers")
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
    count = len(arrays[0])
    title = (f"stable Neo-Hookean on positions, {count} bunny tets, "
             f"float64, {where}: ms for all instances")
    first = f"stable Neo-Hookean, {count:,} tets, f64"
    measured = [row(name, {"yasps": ours[name] * 1e3 if name in ours else None,
                           **{peer: results[(peer, name)] * 1e3
                              for peer in ("PyTorch", "JAX")}})
                for name in ("grad", "hess")]
    if "hess_proj" in ours:
        measured.append(row("hess_proj", {"yasps": ours["hess_proj"] * 1e3}))
    out.values.update(instances=count, device=where, repeat=args.repeat,
                      yasps_log=str(args.yasps_log) if args.yasps_log else None)
    out.table("peers", [first] + COLUMNS, measured, FORMATS,
              f"{title[0].upper()}{title[1:]}; yasps from "
              "yasps-kernel-bench's log, ratios peer / yasps.")
    paper = [row(name, times) for name, times in PAPER_RTX_4090.items()]
    out.table("paper_rtx_4090", ["the paper's RTX 4090"] + COLUMNS, paper,
              FORMATS, "The paper's figures for the same work (ms); the "
              "ratios are what compare across GPUs.")

    print(title)
    for name, cells in zip(("grad", "hess", "hess_proj"), measured):
        _, y, t_ms, t_ratio, j_ms, j_ratio = cells
        line = [f"  {name:6s}"]
        if y is not None:
            line.append(f"yasps {y:8.3f}")
        for peer, ms, ratio in (("PyTorch", t_ms, t_ratio),
                                ("JAX", j_ms, j_ratio)):
            if ms is not None:
                line.append(f"{peer} {ms:9.3f}"
                            + (f" ({ratio:.0f}x)" if ratio is not None else ""))
        print("   ".join(line))
    print("the paper's RTX 4090 (ms; the ratios are what compare):")
    for name, cells in zip(PAPER_RTX_4090, paper):
        _, y, t_ms, t_ratio, j_ms, j_ratio = cells
        line = [f"  {name:6s}", f"yasps {y:8.3f}"]
        for peer, ms, ratio in (("PyTorch", t_ms, t_ratio),
                                ("JAX", j_ms, j_ratio)):
            if ms is not None:
                line.append(f"{peer} {ms:9.3f} ({ratio:.0f}x)")
        print("   ".join(line))
    path = out.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
