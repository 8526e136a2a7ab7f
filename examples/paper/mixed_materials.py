#!/usr/bin/env python3
"""Mixed materials (paper 9.4, Fig. 17).

One bunny of four vertex kinds in one UNION: a fixed strip across its
middle (constants), its two ends two affine bodies (A rest + t, ABD's
orthogonality), and the rest free soft vertices. Stable Neo-Hookean acts on
every tet through the UNION, so the soft part couples the rigid ends to the
fixed strip; the bunny's surface is in self-contact through the same UNION.
Held by the strip, the ends swing down under gravity.

    python3 examples/paper/mixed_materials.py [--frames 60]
        [--scale small|paper] [--output DIR]
"""

from __future__ import annotations

import sys
from typing import Dict

import numpy as np

from common import DT, GRAVITY, arguments, bunny, lame, run  # noqa: E402

import yasps  # noqa: E402
from yasps.contact import Contact  # noqa: E402
from yasps.sim import (Body, ImplicitEuler, add_affine_body,  # noqa: E402
                       add_elastic_tets, add_free_vertices, lumped_masses)

HEIGHT = 0.3
DENSITY = 1000.0


def regions(verts: np.ndarray) -> Dict[str, np.ndarray]:
    """Vertex indices of each region along the bunny's depth (y): the two
    ends (a quarter each), a strip around the middle (a tenth) and the rest."""
    y = verts[:, 1]
    lo, hi = y.min(), y.max()
    length = hi - lo
    front = y < lo + 0.25 * length
    back = y > hi - 0.25 * length
    strip = np.abs(y - (lo + hi) / 2) < 0.05 * length
    soft = ~(front | back | strip)
    return {k: np.nonzero(m)[0] for k, m in
            (("fixed", strip), ("soft", soft), ("front", front),
             ("back", back))}


def build(scale: str):
    """The scene: (stepper, contact, {body: Body}, {region: ...})."""
    verts, tets, faces = bunny(scale, HEIGHT)
    verts = verts + [0.0, 0.0, 0.1]
    masses = lumped_masses(verts, tets, DENSITY)
    parts = regions(verts)
    s = yasps.scene("mixed_materials")
    mesh = s.addMesh("bunny")
    fixed = mesh.addPrimitive("fixed", numInstances=len(parts["fixed"]))
    fixed.addConstant("position", rows=3).updateValue(verts[parts["fixed"]])
    soft = add_free_vertices(s.addMesh("soft"), verts[parts["soft"]],
                             masses[parts["soft"]])
    ends = {}
    for name in ("front", "back"):
        ids = parts[name]
        centre = (masses[ids] @ verts[ids]) / masses[ids].sum()
        ends[name] = add_affine_body(
            s.addMesh(name), verts[ids] - centre, masses[ids],
            stiffness=1e7 * masses[ids].sum() / DENSITY, scale=DT * DT,
            translation=centre)
    members = [fixed, soft.primitive, ends["front"].vertices,
               ends["back"].vertices]
    union = s.addMesh("all").addPrimitiveUnion("v", members)
    union.addAttribute("position")
    # Union index of every bunny vertex: members are laid out in order.
    order = np.concatenate([parts[k] for k in ("fixed", "soft", "front",
                                               "back")])
    where = np.empty(len(verts), dtype=np.int64)
    where[order] = np.arange(len(verts))
    mu, lam = lame(1e4, 0.4)
    add_elastic_tets(s.all, union["position"], verts[order], where[tets], mu,
                     lam, scale=DT * DT)
    contact = Contact(s, union, faces=where[faces], dhat=1e-3,
                      average_mass=float(masses.mean()))
    targets = [soft.x, ends["front"].A, ends["front"].t, ends["back"].A,
               ends["back"].t]
    hats = [soft.x_hat, ends["front"].A_hat, ends["front"].t_hat,
            ends["back"].A_hat, ends["back"].t_hat]
    s.addMinimizeTarget(targets)
    stepper = ImplicitEuler(s, targets, hats, dt=DT,
                            gravity=[GRAVITY, None, GRAVITY, None, GRAVITY],
                            contact=contact)
    bodies = {"bunny": Body(union["position"], where[faces], (0.35, 0.6, 0.9))}
    return stepper, contact, bodies, dict(parts=parts, ends=ends,
                                          where=where, rest=verts)


def main() -> None:
    args = arguments(__doc__.split("\n")[0], frames=60)
    stepper, contact, bodies, _ = build(args.scale)
    summary = run("mixed_materials", args, stepper, bodies, contact,
                  bounds=((-0.25, -0.25, -0.1), (0.25, 0.25, 0.45)))
    sys.exit(1 if summary.intersections else 0)


if __name__ == "__main__":
    main()
