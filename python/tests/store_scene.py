"""A few frames of the README demo's scene (a soft and an affine box on a
pinned cloth, friction), small, for the kernel store's tests: run as a
script in a process of its own.

    python3 store_scene.py OUT.npz [--store] [--chips host] [--frames 3]

``--store`` compiles every kernel into the kernel store
(``yasps.compile(..., store=True)``); ``--chips`` compiles the GPU
kernels for those chips ahead instead of running anything. Otherwise it
compiles (or, without the compiler, finds) the kernels, steps the frames
on the current backend and writes the world positions, the contact's
faces, the compiler requests made and the backend to OUT.npz.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "python"))
sys.path.insert(0, str(REPO / "examples"))

import yasps  # noqa: E402
from yasps.compiler import invocations  # noqa: E402

from contact_demo import build  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("out", type=Path)
    parser.add_argument("--store", action="store_true")
    parser.add_argument("--chips", nargs="+")
    parser.add_argument("--frames", type=int, default=3)
    args = parser.parse_args()

    scene, stepper, contact, bodies = build(4, 1)
    also = [contact.positions, bodies["rigid"].positions]
    if args.chips:
        yasps.compile(scene, also=also, contact=contact, progress=False,
                      backend="gpu", chips=args.chips)
        return
    yasps.compile(scene, also=also, contact=contact, progress=False,
                  store=args.store)
    for _ in range(args.frames):
        stepper.step()
        contact.forces()
    np.savez(args.out, world=contact.world(), faces=contact.mesh.faces,
             requests=json.dumps(invocations()),
             backend=scene.lastSolve["backend"] if args.frames else "")


if __name__ == "__main__":
    main()
