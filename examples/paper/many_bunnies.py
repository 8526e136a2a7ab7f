#!/usr/bin/env python3
"""Many bunnies on cloth (paper 9.2, Fig. 15, Table 5).

Soft bunnies (stable Neo-Hookean, Young's modulus 31.7 kPa, Poisson 0.226,
1 kg) and affine bunnies (ABD: vertices A rest + t, the orthogonality energy
with Young's modulus 9.88 MPa times the volume, 0.5 kg) fall onto a cloth
pinned at its corners (Baraff-Witkin stretch 355 kPa, shear 100 kPa). Every
pair type between both parameterisations goes through one UNION.

    python3 examples/paper/many_bunnies.py [--frames 60] [--bunnies 4]
        [--scale small|paper] [--output DIR]
"""

from __future__ import annotations

import sys

import numpy as np

from common import (CLOTH_CELLS, DT, GRAVITY, arguments, bunny, lame,  # noqa: E402
                    pinned_cloth, run)

import yasps  # noqa: E402
from yasps.contact import Contact  # noqa: E402
from yasps.sim import (Body, ImplicitEuler, add_affine_body,  # noqa: E402
                       add_elastic_tets, add_free_vertices, lumped_masses)

#: Table 5's cloth; its stiffness per unit area, scaled to the small cloth's
#: weight (0.2 kg/m^2).
CLOTH = dict(stretch=355e3 * 1e-2, shear=100e3 * 1e-2, bending=0.055)
CLOTH_DENSITY = 0.2
HEIGHT = 0.2
SOFT, RIGID = (0.35, 0.6, 0.9), (0.85, 0.4, 0.5)


def build(scale: str, count: int):
    """The scene: (stepper, contact, {body: Body}, affine bodies)."""
    s = yasps.scene("many_bunnies")
    n = CLOTH_CELLS[scale]
    cloth, cf, pinned = pinned_cloth(s, scale, CLOTH, CLOTH_DENSITY)

    bv, bt, bf = bunny(scale, HEIGHT)
    volume = lumped_masses(bv, bt, 1.0).sum()
    parts, faces, bodies, affine = [cloth.primitive], [cf], {}, []
    targets, hats, gravity, fixed = [cloth.x], [cloth.x_hat], [GRAVITY], [pinned]
    bodies["cloth"] = Body(cloth.x, cf, (0.85, 0.75, 0.55))
    offset = cloth.primitive.numInstances
    mu, lam = lame(31.7e3, 0.226)
    for k in range(count):
        row, col = divmod(k, 2)
        place = np.array([0.22 * (col - 0.5) * 2 * 0.6, 0.25 * (row - 0.5),
                          0.02 + 0.12 * k])
        mesh = s.addMesh(f"bunny{k}")
        if k % 2 == 0:
            start = bv + place
            masses = lumped_masses(bv, bt, 1.0 / volume)
            b = add_free_vertices(mesh, start, masses)
            add_elastic_tets(mesh, b.x, start, bt, mu, lam, scale=DT * DT)
            parts.append(b.primitive)
            targets.append(b.x)
            hats.append(b.x_hat)
            gravity.append(GRAVITY)
            fixed.append(None)
            bodies[f"soft{k}"] = Body(b.x, bf, SOFT)
        else:
            centre = bv.mean(axis=0)
            body = add_affine_body(mesh, bv - centre,
                                   lumped_masses(bv, bt, 0.5 / volume),
                                   stiffness=9.88e6 * volume, scale=DT * DT,
                                   translation=centre + place)
            parts.append(body.vertices)
            targets += [body.A, body.t]
            hats += [body.A_hat, body.t_hat]
            gravity += [None, GRAVITY]
            fixed += [None, None]
            bodies[f"rigid{k}"] = Body(body.vertices["position"], bf, RIGID)
            affine.append(body)
        faces.append(bf + offset)
        offset += len(bv)

    union = s.addMesh("all").addPrimitiveUnion("v", parts)
    union.addAttribute("position")
    contact = Contact(s, union, faces=np.concatenate(faces), dhat=1e-3,
                      average_mass=CLOTH_DENSITY / (n + 1) ** 2, friction=0.1)
    s.addMinimizeTarget(targets)
    stepper = ImplicitEuler(s, targets, hats, dt=DT, gravity=gravity,
                            fixed=fixed, contact=contact)
    return stepper, contact, bodies, affine


def main() -> None:
    args = arguments(__doc__.split("\n")[0], frames=60, extra=lambda p:
                     p.add_argument("--bunnies", type=int, default=4))
    stepper, contact, bodies, _ = build(args.scale, args.bunnies)
    summary = run("many_bunnies", args, stepper, bodies, contact,
                  bounds=((-0.55, -0.55, -0.35), (0.55, 0.55, 0.65)))
    sys.exit(1 if summary.intersections else 0)


if __name__ == "__main__":
    main()
