#!/usr/bin/env python3
"""Compiles the per-instance derivative kernels of stable Neo-Hookean on the
79,935 bunny tets for GPUs, for timing on a machine without this toolchain.

    python3 bench/gpu_kit.py KIT

Writes into KIT: the kernels' cubins (sm_80, sm_90) and PTX, the launch
record ``kernels.txt`` that ``yasps-kernel-bench`` reads, the scene's input
buffers and the CPU kernels' outputs for the first instances (.npy), and the
formula's inputs ``x.npy`` (N, 12) and ``dm_inv.npy`` (N, 9) with which
bench/gpu_peers.py times PyTorch and JAX on the same tets.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-kit-"))
HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "python"))
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402

import yasps.gpu  # noqa: E402
from yasps.emit import emit_scene  # noqa: E402
from yasps.evaluate import DIFFERENTIATION_PIPELINE, _buffer  # noqa: E402

from energy_cases import CASES  # noqa: E402
from meshes import bunny  # noqa: E402

#: Instances whose CPU values the kit keeps for checking the GPU's.
CHECKED = 2000
KERNELS = ("grad", "hess", "hess_proj")


def bunny_snh_inputs():
    """Current positions (N, 12) and inverse rest shapes (N, 9) of the
    bunny's tets, positions perturbed (the same as bench/gpu.py)."""
    verts, tets = bunny("19k")
    rng = np.random.default_rng(0)
    rest = verts[tets]
    cur = rest + rng.normal(scale=1e-3 * np.abs(verts).max(), size=rest.shape)
    dm_inv = np.linalg.inv(np.stack([rest[:, k] - rest[:, 0]
                                     for k in (1, 2, 3)], axis=2))
    return cur.reshape(-1, 12), dm_inv.reshape(-1, 9)


def main() -> None:
    kit = Path(sys.argv[1])
    kit.mkdir(parents=True, exist_ok=True)
    arrays = bunny_snh_inputs()
    np.save(kit / "x.npy", arrays[0])
    np.save(kit / "dm_inv.npy", arrays[1])
    case = next(c for c in CASES if c.name == "stable Neo-Hookean (x, 12)")
    energy = case.build(arrays)
    scene = energy.scene
    paths = [energy.path(k) for k in KERNELS]
    kernels = yasps.gpu.compile_ir(emit_scene(scene), paths, scene.name,
                                   DIFFERENTIATION_PIPELINE,
                                   chips=("sm_80", "sm_90"))
    lines = [f"count {energy.count}"]
    for (chip, fmt), data in sorted(kernels.binaries.items()):
        name = f"snh_{chip}.{fmt}"
        (kit / name).write_bytes(data)
        lines.append(f"image {chip} {fmt} {name}")

    # The CPU kernels' values of the first instances, for the check.
    cpu = scene.energyDerivatives(energy.attr)
    references = {"grad": cpu.gradient, "hess": cpu.hessian,
                  "hess_proj": cpu.projectedHessian}
    written = set()
    for label, path in zip(KERNELS, paths):
        kernel = kernels.kernel(path)
        reference = f"{label}_reference.npy"
        # Column-major per instance; Hessians are symmetric.
        np.save(kit / reference,
                np.ascontiguousarray(references[label][:CHECKED]).reshape(-1))
        lines.append(f"kernel {kernel.name} {label} {kernel.threads_per_block} "
                     f"{energy.count * kernel.rows * kernel.cols} {reference}")
        lines += [f"param {kind} {value}" for kind, value in kernel.launch_params]
        for kind, p in kernel.arguments:
            if kind == "out":
                lines.append("buffer out")
                continue
            name = f"{kind}_{p.replace('@', '').replace('::', '.')}.npy"
            if name not in written:
                np.save(kit / name, np.ascontiguousarray(
                    _buffer(scene, kind, p, None)))
                written.add(name)
            lines.append(f"buffer {name}")
        lines.append("end")
    (kit / "kernels.txt").write_text("\n".join(lines) + "\n")
    print(f"{kit}: {len(KERNELS)} kernels for {energy.count} tets")


if __name__ == "__main__":
    main()
