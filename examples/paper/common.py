"""What the paper's scene scripts share: their command line, the bunny meshes
of ../shared/data, material constants, and the run to files with its summary.
Each scene script builds its scene in its own file; this holds no physics."""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Tuple

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "python"))

from yasps.contact import surface_of  # noqa: E402
# lame: the scene scripts import it from here too.
from yasps.sim import (FreeVertices, RunSummary, add_cloth,  # noqa: E402,F401
                       add_free_vertices, cloth_corners, cloth_grid,
                       lame, lumped_masses, read_tet_mesh, simulate)

#: The meshes: ../shared/data, or the folder $YASPS_DATA_DIR names (a GPU
#: machine's device kit carries them elsewhere).
DATA = Path(os.environ.get("YASPS_DATA_DIR") or REPO.parent / "shared" / "data")
DT = 0.01
GRAVITY = (0.0, 0.0, -9.81)

#: The paper's sizes (Table 1, Table 5) and the small ones of the tests.
BUNNY = {"small": "bunny-1.8k.msh", "paper": "bunny-19k.msh"}
CLOTH_CELLS = {"small": 24, "paper": 100}


def arguments(description: str, frames: int,
              extra=lambda parser: None) -> argparse.Namespace:
    """The scene scripts' common options, and those ``extra(parser)`` adds."""
    parser = argparse.ArgumentParser(description=description)
    extra(parser)
    parser.add_argument("--frames", type=int, default=frames)
    parser.add_argument("--scale", choices=("small", "paper"), default="small")
    parser.add_argument("--output", type=Path, default=None,
                        help="default: out/paper/<scene>")
    parser.add_argument("--no-video", action="store_true")
    return parser.parse_args()


def bunny(scale: str, height: float
          ) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The tet bunny of ``scale`` ("small", "paper"; or a mesh's file name
    in ../shared/data) standing on z = 0, centred in x and y, ``height``
    tall: (vertices, tets, surface triangles)."""
    path = DATA / BUNNY.get(scale, scale)
    if not path.exists():
        raise SystemExit(f"{path} is missing: the paper's scenes read the "
                         f"bunny meshes from ../shared/data")
    verts, tets = read_tet_mesh(path)
    lo, hi = verts.min(axis=0), verts.max(axis=0)
    verts = (verts - [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]]) \
        * (height / (hi[2] - lo[2]))
    return verts, tets, surface_of(tets)


def pinned_cloth(scene, scale, material: dict, density: float,
                 size: float = 1.0
                 ) -> Tuple[FreeVertices, np.ndarray, np.ndarray]:
    """The scenes' bottom cloth: a ``size`` m square at z = 0 of
    CLOTH_CELLS[scale] cells (or ``scale`` cells where it is a number;
    ``material``: add_cloth's stretch, shear and bending; ``density`` per
    area), its four corners pinned: (vertices, triangles, pinned mask)."""
    n = scale if isinstance(scale, int) else CLOTH_CELLS[scale]
    verts, faces = cloth_grid(n, size=size)
    mesh = scene.addMesh("cloth")
    cloth = add_free_vertices(mesh, verts, lumped_masses(verts, faces, density))
    add_cloth(mesh, cloth.x, verts, faces, scale=DT * DT, **material)
    pinned = np.zeros(len(verts), dtype=bool)
    pinned[cloth_corners(n)] = True
    return cloth, faces, pinned


def run(name: str, args, stepper, bodies, contact, **options) -> RunSummary:
    """Compiles (or loads) the kernels, simulates ``args.frames`` frames to
    ``args.output`` and prints the summary line and the time per stage."""
    output = args.output or REPO / "out" / "paper" / name
    start = time.perf_counter()
    contact.update()
    stepper.scene.evaluateEnergy()
    stepper.scene.minimizeEnergy(fixed=stepper.fixed)
    print(f"{name}: compiled or loaded the kernels in "
          f"{time.perf_counter() - start:.1f} s")
    summary = simulate(stepper, bodies, args.frames, output, contact=contact,
                       video=not args.no_video, **options)
    print(f"{name}: {summary.line()}")
    print(summary.stages())
    print(f"{name}: wrote {output}")
    return summary
