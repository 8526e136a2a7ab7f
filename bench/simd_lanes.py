#!/usr/bin/env python3
"""SIMD lanes on the CPU: each energy's kernels one instance at a time
against several instances per vector instruction.

For every energy of ``bench/benchlib/energy_cases.py`` the gradient, Hessian and
projected-Hessian kernels are compiled twice, with ``yasps.config.simd_lanes
= 1`` (scalar code, one instance per loop iteration) and with the host's
vector width (``simd_lanes = 0``), checked to agree, and timed alternately on
the same instances, one thread. Prints the time per instance of each and the
speed-up.

    python3 bench/simd_lanes.py [--count 20000] [--repeat 5] [--json PATH]
"""

from __future__ import annotations

import argparse
import os
import tempfile
from pathlib import Path

os.environ.setdefault("YASPS_CACHE_DIR", tempfile.mkdtemp(prefix="yasps-bench-"))
HERE = Path(__file__).resolve().parent
import benchlib  # noqa: E402

benchlib.use_this_checkout()

import numpy as np  # noqa: E402

import yasps  # noqa: E402
from benchlib.energy_cases import CASES  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402
from benchlib.timing import median  # noqa: E402

KERNELS = ("grad", "hess", "hess_proj")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=5)
    add_json_argument(parser, "simd_lanes")
    args = parser.parse_args()
    n = args.count
    lanes = yasps.compiler.native().host_double_lanes()
    results = Results("simd_lanes")
    results.values.update(count=n, repeat=args.repeat, lanes=lanes)
    title = (f"{n} instances, one thread, median of {args.repeat}; time per "
             f"instance with 1 lane / {lanes} lanes (speed-up)")
    print(title)
    print(f"{'energy':34s}" + "".join(f"{k:>26s}" for k in KERNELS))
    # Per kernel three columns, printed as one: "t1 / tN ns (speed-up)".
    columns, formats = ["energy"], [""]
    for k in KERNELS:
        columns += [f"{k}, 1 lane", f"{k}, {lanes} lanes", f"{k} speed-up"]
        formats += ["{:.0f} ns", "{:.0f} ns", "{:.1f}x"]
    rows = []
    for case in CASES:
        energy = case.build(case.instances(n))
        runs = {}
        for setting in (1, 0):
            yasps.config.simd_lanes = setting
            _, library, launches = energy.kernels(list(KERNELS))
            outputs = []
            for path, launch in zip(KERNELS, launches):
                launch()
                outputs.append(launch.args[3][0].copy())  # the "out" buffer
            runs[setting] = (launches, outputs)
        yasps.config.simd_lanes = 0
        row = [case.name]
        for k, name in enumerate(KERNELS):
            scalar, vector = runs[1][0][k], runs[0][0][k]
            a, b = runs[1][1][k], runs[0][1][k]
            # Same values up to rounding (the projection's eigensolver
            # takes different iteration counts in lockstep).
            np.testing.assert_allclose(b, a, rtol=1e-9,
                                       atol=1e-9 * np.abs(a).max())
            t1 = median(scalar, args.repeat)
            t8 = median(vector, args.repeat)
            row += [t1 * 1e9 / n, t8 * 1e9 / n, t1 / t8]
        rows.append(row)
        cells = [f"{row[i]:8.0f} /{row[i + 1]:6.0f} ns ({row[i + 2]:4.1f}x)"
                 for i in range(1, len(row), 3)]
        print(f"{case.name:34s}" + "".join(f"{c:>26s}" for c in cells),
              flush=True)
    results.table("simd_lanes", columns, rows, formats, f"{title}.")
    path = results.write(args.json)
    print(f"results: {path}")


if __name__ == "__main__":
    main()
