#!/usr/bin/env python3
"""Compiles bunny kernels for GPUs into kits (runtime/bench/Kit.h), for
timing on a GPU machine without this toolchain.

    python3 bench/gpu_kit.py KIT

Writes two kits under KIT, each with the kernels' cubins (sm_80, sm_90),
PTX and host image (which the stand-in driver runs in a dry run of
scripts/device_check.sh), the launch record ``kernels.txt``, the scene's input buffers and the
CPU kernels' values of the first instances (.npy):

- ``snh``: gradient, Hessian and projected Hessian of stable Neo-Hookean on
  positions over the 79,935 bunny tets (``yasps-kernel-bench``); its input
  buffers also give bench/gpu_peers.py the formula's inputs, with which it
  times PyTorch and JAX on the same tets (``peer_inputs``);
- ``newton``: the gradient, projected-Hessian and placement-index kernels of
  bench/newton_system.py's scene (stable Neo-Hookean + inertia on the
  bunny), its DoF layout and the CPU's Newton direction
  (``yasps-newton-bench`` runs one Newton iteration's stages on the GPU).
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path
from typing import Dict, List, Tuple

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-kit-"))
HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

import numpy as np  # noqa: E402

import yasps.compiler.gpu  # noqa: E402
from yasps.compiler.pipelines import DIFFERENTIATION_PIPELINE  # noqa: E402
from yasps.ir import emit_scene  # noqa: E402
from yasps.runtime import cpu_backend  # noqa: E402
from yasps.runtime.inputs import host_input  # noqa: E402
from yasps.solve import DofLayout, assemble  # noqa: E402

from benchlib.energy_cases import CASES  # noqa: E402
from benchlib.elastic_scenes import bunny_snh, bunny_snh_inputs  # noqa: E402
from benchlib.kit_files import peer_inputs  # noqa: E402

#: Instances whose CPU values a kit keeps for checking the GPU's.
CHECKED = 2000
#: The Newton direction's PCG tolerance (tight, so that both backends'
#: solutions agree closely).
NEWTON_TOLERANCE = 1e-10


def write_kit(kit: Path, scene, kernels: List[Tuple[str, str, int, np.ndarray]],
              extra: List[str]) -> None:
    """Compiles ``kernels`` (label, scene-relative path, instances, CPU
    values (N, ...)) of ``scene`` and writes the kit with ``extra``
    directives."""
    kit.mkdir(parents=True, exist_ok=True)
    compiled = yasps.compiler.gpu.compile_ir(
        emit_scene(scene, locations=True), [p for _, p, _, _ in kernels],
        scene.name, DIFFERENTIATION_PIPELINE,
        chips=("sm_80", "sm_90", "host"))
    lines = []
    for (chip, fmt), data in sorted(compiled.binaries.items()):
        name = f"kernels_{chip}.{fmt}"
        (kit / name).write_bytes(data)
        lines.append(f"image {chip} {fmt} {name}")
    written = set()
    for label, path, count, values in kernels:
        kernel = compiled.kernel(path)
        reference = f"{label}_reference.npy"
        # Column-major per instance (vectors and symmetric matrices read the
        # same either way).
        np.save(kit / reference, np.ascontiguousarray(
            values[:CHECKED], dtype=np.float64).reshape(-1))
        lines.append(f"kernel {kernel.name} {label} {kernel.threads_per_block} "
                     f"{count} {count * kernel.rows * kernel.cols} {reference}")
        lines += [f"param {kind} {value}" for kind, value in kernel.launch_params]
        for argument in kernel.arguments:
            kind, p = argument.kind.name, argument.path
            if kind == "out":
                lines.append("buffer out")
                continue
            name = f"{kind}_{p.replace('@', '').replace('::', '.')}.npy"
            if name not in written:
                np.save(kit / name, np.ascontiguousarray(
                    host_input(scene, argument)))
                written.add(name)
            lines.append(f"buffer {name}")
    (kit / "kernels.txt").write_text("\n".join(lines + extra) + "\n")


def snh_kit(kit: Path) -> None:
    arrays = bunny_snh_inputs()
    case = next(c for c in CASES if c.name == "stable Neo-Hookean (x, 12)")
    energy = case.build(arrays)
    cpu = energy.scene.energyDerivatives(energy.attr)
    values = {"grad": cpu.gradient, "hess": cpu.hessian,
              "hess_proj": cpu.projectedHessian}
    write_kit(kit, energy.scene,
              [(k, energy.path(k), energy.count, v) for k, v in values.items()],
              [])
    for got, want in zip(peer_inputs(kit), arrays):
        assert np.array_equal(got, want), "the SNH kit's buffers changed layout"


def newton_kit(kit: Path) -> None:
    scene = bunny_snh()
    kernels, energies = [], []
    for energy in scene.energies:
        base = "::".join("@" + n for n in energy.owner.path + [energy.name])
        d = scene.energyDerivatives(energy)
        count, n = d.gradient.shape
        values: Dict[str, np.ndarray] = {
            "grad": d.gradient, "hess_proj": d.projectedHessian,
            # 1-based in the kernel, 0 for padding.
            "dofs": d.dofs() + 1}
        for kind, v in values.items():
            kernels.append((f"{energy.name}.{kind}", f"{base}__{kind}", count, v))
        energies.append(f"energy {energy.name} {count} {n} {energy.name}.grad "
                        f"{energy.name}.hess_proj {energy.name}.dofs")
    kit.mkdir(parents=True, exist_ok=True)
    np.save(kit / "layout.npy", DofLayout(scene.minimizeTargets).block_offsets)
    system = assemble(scene, cpu_backend()).system
    solution = np.zeros(system.size)
    report = system.solve(solution, NEWTON_TOLERANCE, 10000, 0, None)
    assert report.converged, "the CPU's Newton direction did not converge"
    np.save(kit / "solution.npy", solution)
    write_kit(kit, scene, kernels, energies + [
        "layout layout.npy", f"solution solution.npy {NEWTON_TOLERANCE}"])


def main() -> None:
    kit = Path(sys.argv[1])
    snh_kit(kit / "snh")
    newton_kit(kit / "newton")
    print(f"{kit}: snh (stable Neo-Hookean, 79935 tets), newton (bunny scene)")


if __name__ == "__main__":
    main()
