#!/usr/bin/env python3
"""Two soft boxes in IPC contact: one resting on the ground (a half-space),
the other dropped onto it.

Both are free vertices with stable Neo-Hookean tets, in one UNION whose
positions `yasps.contact.Contact` hands to ipctk; the ground is a
half-space. `build` makes the scene (tests and bench/accuracy_speed.py
vary its precision, projection, dhat and barrier stiffness); run as a
script it steps a few frames and prints the lowest point and the gap.

    python3 examples/soft_boxes.py [--frames 20]
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

import yasps  # noqa: E402
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.sim import (ImplicitEuler, add_elastic_tets,  # noqa: E402
                       add_free_vertices, box_tet_mesh)

DT = 0.01
DHAT = 1e-3     # the contact's activation distance (m)
SIZE = 0.2      # each box's edge (m)


@dataclass
class SoftBoxes:
    """The scene's handles: its targets and predictions (low box, high
    box), the surface triangles of both (vertex numbering low then high),
    and the contact."""
    scene: yasps.Scene
    xs: List[yasps.Attribute]
    hats: List[yasps.Attribute]
    faces: np.ndarray
    contact: Contact

    def stepper(self, **options) -> ImplicitEuler:
        """Implicit Euler over both boxes under gravity, with the contact
        (``options``: ImplicitEuler's tolerances and limits)."""
        return ImplicitEuler(self.scene, self.xs, self.hats, DT,
                             gravity=[(0, 0, -9.81)] * 2,
                             contact=self.contact, **options)

    def positions(self) -> np.ndarray:
        """Both boxes' vertices (N, 3), low box first."""
        return np.concatenate([x.value[:, :, 0] for x in self.xs])


def build(lift: float = 0.23, precision: Optional[str] = None,
          projection: str = "clamp", dhat: float = DHAT,
          kappa: Optional[float] = None, name: str = "soft_on_soft"
          ) -> SoftBoxes:
    """Two boxes of 2^3 cells (mu = lambda = 2e4), the low one 0.5 mm above
    the ground, the high one ``lift`` above it and shifted 3 cm sideways.
    ``precision``, ``projection``, ``dhat`` and ``kappa`` (None: IPC's
    adaptive stiffness) are the scene's and the contact's."""
    verts, tets = box_tet_mesh(2, SIZE)
    faces = surface_of(tets).astype(np.int32)
    s = yasps.scene(name, precision=precision)
    xs, hats, prims = [], [], []
    for box, height in (("low", 5e-4), ("high", lift)):
        mesh = s.addMesh(box)
        start = verts + [0.03 if box == "high" else 0.0, 0.02, height]
        free = add_free_vertices(mesh, start, 0.1, projection=projection)
        add_elastic_tets(mesh, free.x, start, tets, 2e4, 2e4, scale=DT * DT,
                         projection=projection)
        xs.append(free.x)
        hats.append(free.x_hat)
        prims.append(free.primitive)
    union = s.addMesh("all").addPrimitiveUnion("v", prims)
    union.addAttribute("position")
    both = np.concatenate([faces, faces + len(verts)])
    contact = Contact(s, union, faces=both, dhat=dhat, kappa=kappa,
                      average_mass=0.1, halfspaces=[((0, 0, 0), (0, 0, 1))],
                      projection=projection)
    s.addMinimizeTarget(xs)
    return SoftBoxes(s, xs, hats, both, contact)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=20)
    args = parser.parse_args()
    boxes = build()
    stepper = boxes.stepper()
    for frame in range(args.frames):
        report = stepper.step()
        low, high = (x.value[:, 2, 0] for x in boxes.xs)
        print(f"frame {frame + 1:3d}: lowest z {low.min() * 100:6.2f} cm, gap "
              f"{(high.min() - low.max()) * 1000:7.2f} mm, Newton "
              f"{report.iterations}")


if __name__ == "__main__":
    main()
