#!/usr/bin/env python3
"""PSD projection through linear maps, on and off, per energy.

For each energy of bench/benchlib/energy_cases.py, N instances are compiled twice:
with ``linear-maps=true`` (yasps' default: where the energy reaches its
parameters through a linear cut with fewer entries, such as a tet's
deformation gradient, the Hessian is projected in the cut's entries, J^T
P(H_cut) J, paper 10.4) and with ``linear-maps=false`` (projected in the
leaves' entries or the parameters, as before). Prints, per energy, the size
of the projected matrix each way, the time per instance of the Hessian and
of the projected-Hessian kernel (one thread, median). It also checks what the two must share: the projected
Hessians are PSD, and where the Hessian is PSD they agree.

    python3 bench/linear_maps.py [--count 20000] [--repeat 7] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import tempfile
from functools import partial
from pathlib import Path

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))
HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

import numpy as np  # noqa: E402

from benchlib import energy_cases as cases  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.timing import median  # noqa: E402
from yasps.compiler.cpu import compile_cpu  # noqa: E402
from yasps.ir import emit_scene  # noqa: E402
from yasps.runtime.cpu import launch as launch_cpu  # noqa: E402
from yasps.runtime.inputs import host_input  # noqa: E402
from yasps.compiler.params import ArgumentKind  # noqa: E402


def pipeline(linear_maps: bool) -> str:
    flag = "true" if linear_maps else "false"
    return ("yasps-differentiate-pipeline{hessian-factors=never "
            f"linear-maps={flag}}}")


def run(energy: cases.YaspsEnergy, linear_maps: bool, repeat: int):
    """Per-instance ns of hess and hess_proj and their outputs: the
    Hessians and the projected Hessians (N, n, n)."""
    paths = [energy.path("hess"), energy.path("hess_proj")]
    kernels = compile_cpu(emit_scene(energy.scene), paths, energy.scene.name,
                          pipeline(linear_maps))
    times, outputs = [], []
    for path in paths:
        kernel = kernels.kernel(path)
        out = np.empty(energy.count * kernel.rows * kernel.cols,
                       dtype=kernel.out_dtype)
        buffers = [out if a.kind is ArgumentKind.out else host_input(energy.scene, a)
                   for a in kernel.arguments]
        launch = partial(launch_cpu, kernels, path, energy.count, buffers, 1)
        launch()
        times.append(median(launch, repeat) / energy.count * 1e9)
        outputs.append(out.reshape(energy.count, kernel.rows, kernel.cols).copy())
    return times, outputs


def projected_size(energy: cases.YaspsEnergy, linear_maps: bool) -> int:
    """The size of the matrix the projection decomposes, from the IR."""
    from yasps.compiler import run_pipeline
    text = run_pipeline(emit_scene(energy.scene), pipeline(linear_maps))
    marker = "yasps.project "
    for line in text.splitlines():
        if marker in line and "__hess_proj" not in line:
            return int(line.rsplit("mat<", 1)[1].split("x", 1)[0])
    return 0


#: The table's columns and their formats; "proj off" and "proj on" (the
#: size of the matrix each way) are printed as one column "proj", "off->on".
#: Times are ns per instance.
COLUMNS = ["energy", "proj off", "proj on", "hess", "+proj off", "+proj on",
           "speed-up"]
FORMATS = ["", "{:d}", "{:d}", "{:.0f}ns", "{:.0f}ns", "{:.0f}ns", "{:.2f}x"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=7)
    add_json_argument(parser, "linear_maps")
    args = parser.parse_args()
    results = Results("linear_maps")
    results.values.update(count=args.count, repeat=args.repeat)
    title = (f"{args.count} instances, one thread, median of {args.repeat}; "
             "per instance")
    print(title)
    print(f"{'energy':36s} {'proj':>7s} {'hess':>8s} {'+proj off':>10s} "
          f"{'+proj on':>9s} {'speed-up':>9s}")
    rows = []
    for case in cases.CASES:
        energy = case.build(case.instances(args.count))
        off = run(energy, False, args.repeat)
        on = run(energy, True, args.repeat)
        H, P_off, P_on = off[1][0], off[1][1], on[1][1]
        scale = np.abs(H).max() + 1e-300
        for P in (P_off, P_on):
            assert np.linalg.eigvalsh(P).min(axis=1).min() >= -1e-9 * scale, \
                f"{case.name}: a projected Hessian is not PSD"
        psd = np.linalg.eigvalsh(H).min(axis=1) >= 1e-9 * scale
        if psd.any():
            assert np.abs(P_on[psd] - P_off[psd]).max() <= 1e-9 * scale, \
                f"{case.name}: PSD Hessians changed by the projection"
        row = [case.name, projected_size(energy, False),
               projected_size(energy, True), off[0][0], off[0][1], on[0][1],
               off[0][1] / on[0][1]]
        rows.append(row)
        name, size_off, size_on, hess, proj_off, proj_on, speed_up = row
        sizes = f"{size_off}->{size_on}"
        print(f"{name:36s} {sizes:>7s} {hess:6.0f}ns {proj_off:8.0f}ns "
              f"{proj_on:7.0f}ns {speed_up:8.2f}x", flush=True)
    results.table("linear_maps", COLUMNS, rows, FORMATS,
                  f"{title}. \"proj off\" and \"proj on\": the size of the "
                  "matrix the projection decomposes with linear-maps=false "
                  "and true; \"hess\": the Hessian kernel; \"+proj off\" and "
                  "\"+proj on\": the projected-Hessian kernel each way; "
                  "speed-up: off / on.")
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
