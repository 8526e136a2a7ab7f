#!/usr/bin/env python3
"""The yasps side of bench/stark_peer.py: runs one scene of
bench/benchlib/stark_scenes.py in a process of its own and writes the same
per-frame arrays as bench/stark_driver.py (``--frames 0`` only compiles or
loads the kernels). bench/stark_peer.py starts it:

    python3 bench/stark_yasps_side.py twist|bunny --frames N --threads T \\
        [--newton-cap K] --output RUN.npz
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import benchlib

benchlib.use_this_checkout()
from benchlib.memory import peak_rss_kb
from benchlib.results import commit
from benchlib.stark_scenes import SCENES, run_yasps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scene", choices=sorted(SCENES))
    parser.add_argument("--frames", type=int, required=True)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--newton-cap", type=int, default=None,
                        help="Newton's iteration cap (default: "
                        "ImplicitEuler's)")
    parser.add_argument("--output", type=Path, required=True)
    args = parser.parse_args()
    run = run_yasps(args.scene, args.frames, args.threads, args.newton_cap)
    # The commit measured, for summaries made later (stark_peer --no-run).
    # The process's peak resident memory (kB): mesh, matrices and code.
    run["peak_rss_kb"] = np.array(peak_rss_kb())
    np.savez(args.output, commit=np.array(commit()), **run)


if __name__ == "__main__":
    main()
