#!/usr/bin/env python3
"""A cloth draped over a static box, with IPC contact and friction.

The cloth's free vertices (Baraff-Witkin stretch and shear, dihedral
bending) and the box's vertices, constants, are one UNION whose positions
`yasps.contact.Contact` hands to ipctk: the box is an obstacle. `build`
makes the scene (a test and bench/accuracy_speed.py vary its projection,
dhat and barrier stiffness); run as a script it steps a few frames and
prints the cloth's lowest point.

    python3 examples/cloth_drape.py [--frames 20]
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

import yasps  # noqa: E402
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.sim import (ImplicitEuler, add_cloth,  # noqa: E402
                       add_free_vertices, box_tet_mesh, cloth_grid)

DT = 0.01
DHAT = 2e-3     # the contact's activation distance (m)


@dataclass
class ClothDrape:
    """The scene's handles: the cloth's target and prediction, the box's
    vertices (constants), the surface triangles (cloth first, then the
    box's) and the contact."""
    scene: yasps.Scene
    x: yasps.Attribute
    x_hat: yasps.Attribute
    box: np.ndarray
    faces: np.ndarray
    contact: Contact

    def stepper(self, **options) -> ImplicitEuler:
        """Implicit Euler of the cloth under gravity, with the contact
        (``options``: ImplicitEuler's tolerances and limits)."""
        return ImplicitEuler(self.scene, self.x, self.x_hat, DT,
                             contact=self.contact, **options)


def build(projection: str = "clamp", dhat: float = DHAT,
          kappa: Optional[float] = None) -> ClothDrape:
    """A 10x10 cloth 0.6 m wide, 1 cm above a 0.2 m box, friction 0.3.
    ``projection``, ``dhat`` and ``kappa`` (None: IPC's adaptive stiffness)
    are the energies' and the contact's."""
    cv, cf = cloth_grid(10, size=0.6, height=0.21)
    bv, bt = box_tet_mesh(1, 0.2)
    bv = bv - [0.1, 0.1, 0.0]
    s = yasps.scene("drape")
    cloth = s.addMesh("cloth")
    free = add_free_vertices(cloth, cv, 0.3 / len(cv), projection=projection)
    add_cloth(cloth, free.x, cv, cf, stretch=1e3, shear=1e2, bending=1e-3,
              scale=DT * DT, projection=projection)
    obstacle = s.addMesh("box").addPrimitive("v", numInstances=len(bv))
    obstacle.addConstant("position", rows=3).updateValue(bv)
    union = s.addMesh("all").addPrimitiveUnion("v", [free.primitive, obstacle])
    union.addAttribute("position")
    faces = np.concatenate([cf, surface_of(bt) + len(cv)]).astype(np.int32)
    contact = Contact(s, union, faces=faces, dhat=dhat, kappa=kappa,
                      average_mass=0.3 / len(cv), friction=0.3,
                      projection=projection)
    s.addMinimizeTarget(free.x)
    return ClothDrape(s, free.x, free.x_hat, bv, faces, contact)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=20)
    args = parser.parse_args()
    drape = build()
    stepper = drape.stepper()
    for frame in range(args.frames):
        report = stepper.step()
        print(f"frame {frame + 1:3d}: lowest z "
              f"{drape.x.value[:, 2, 0].min() * 100:6.2f} cm, Newton "
              f"{report.iterations}")


if __name__ == "__main__":
    main()
