#!/usr/bin/env python3
"""SIMD lanes on the CPU: each energy's kernels one instance at a time
against several instances per vector instruction.

For every energy of ``bench/benchlib/energy_cases.py`` the gradient, Hessian and
projected-Hessian kernels are compiled twice, with ``yasps.config.simd_lanes
= 1`` (scalar code, one instance per loop iteration) and with the host's
vector width (``simd_lanes = 0``), checked to agree, and timed alternately on
the same instances, one thread. Prints the time per instance of each and the
speed-up.

    python3 bench/simd_lanes.py [--count 20000] [--repeat 5]
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
from benchlib.timing import median  # noqa: E402

KERNELS = ("grad", "hess", "hess_proj")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--count", type=int, default=20000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    n = args.count
    lanes = yasps.compiler.native().host_double_lanes()
    print(f"{n} instances, one thread, median of {args.repeat}; time per "
          f"instance with 1 lane / {lanes} lanes (speed-up)")
    print(f"{'energy':34s}" + "".join(f"{k:>26s}" for k in KERNELS))
    for case in CASES:
        energy = case.build(case.instances(n))
        runs = {}
        for setting in (1, 0):
            yasps.config.simd_lanes = setting
            _, library, launches = energy.kernels(list(KERNELS))
            outputs = []
            for path, launch in zip(KERNELS, launches):
                launch()
                outputs.append(launch.args[2][0].copy())  # the "out" buffer
            runs[setting] = (launches, outputs)
        yasps.config.simd_lanes = 0
        cells = []
        for k, name in enumerate(KERNELS):
            scalar, vector = runs[1][0][k], runs[0][0][k]
            a, b = runs[1][1][k], runs[0][1][k]
            # Same values up to rounding (the projection's eigensolver
            # takes different iteration counts in lockstep).
            np.testing.assert_allclose(b, a, rtol=1e-9,
                                       atol=1e-9 * np.abs(a).max())
            t1 = median(scalar, args.repeat)
            t8 = median(vector, args.repeat)
            cells.append(f"{t1 * 1e9 / n:8.0f} /{t8 * 1e9 / n:6.0f} ns "
                         f"({t1 / t8:4.1f}x)")
        print(f"{case.name:34s}" + "".join(f"{c:>26s}" for c in cells),
              flush=True)


if __name__ == "__main__":
    main()
