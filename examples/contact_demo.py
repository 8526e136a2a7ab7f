#!/usr/bin/env python3
"""A soft box and an affine box fall onto a cloth pinned at its corners.

Three parameterisations in one contact: free cloth vertices (Baraff-Witkin
stretch and shear, dihedral bending), free soft-body vertices (stable
Neo-Hookean) and the vertices of an affine body (A rest + t, ABD's
orthogonality energy), all in one UNION whose world positions
`yasps.contact.Contact` hands to ipctk. IPC's barrier with its adaptive
stiffness and lagged friction act on every pair; implicit Euler takes
Newton steps over the four targets (cloth, soft, A, t) with CCD step bounds.

    python3 examples/contact_demo.py [--frames 50] [--cloth 40] [--output out/contact]

Writes a ParaView series per body (`<output>/<body>.pvd`), a picture of
chosen frames (`frames.png`), a video (`contact.mp4`, or a GIF without
ffmpeg), and prints a progress bar and the time per stage.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Dict, List

import numpy as np
from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

import yasps  # noqa: E402
from yasps import energies as E  # noqa: E402
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.sim import (ImplicitEuler, NewtonReport, SurfaceRecorder,  # noqa: E402
                       add_affine_body, add_cloth, add_elastic_tets,
                       box_tet_mesh, cloth_corners, cloth_grid,
                       render_surfaces, render_surfaces_array, write_video)

DT = 0.01
DENSITY = 200.0  # of both boxes, kg/m^3: 1.6 kg each
GRAVITY = np.array([0.0, 0.0, -9.81])
COLORS = {"cloth": (0.85, 0.75, 0.55), "soft": (0.35, 0.6, 0.9),
          "rigid": (0.9, 0.45, 0.35)}


def tet_masses(verts: np.ndarray, tets: np.ndarray, density: float) -> np.ndarray:
    """Lumped vertex masses: a quarter of each tet's mass to its corners."""
    c = verts[tets]
    volumes = np.abs(np.linalg.det(np.stack([c[:, k] - c[:, 0]
                                             for k in (1, 2, 3)], 2))) / 6
    masses = np.zeros(len(verts))
    np.add.at(masses, tets.reshape(-1), np.repeat(volumes / 4, 4))
    return density * masses


def free_vertices(mesh, start: np.ndarray, masses: np.ndarray):
    """Free vertices at ``start`` with their inertia: (primitive, x, x_hat)."""
    v = mesh.addPrimitive("v", numInstances=len(start))
    x = v.addAttribute("position", rows=3)
    x.updateValue(start)
    x_hat = v.addConstant("x_hat", rows=3)
    x_hat.updateValue(start)
    v.addConstant("mass", rows=1).updateValue(masses[:, None])
    mesh.scene.addEnergy(v.addAttribute("inertia", computed_attribute=E.inertia(
        x, x_hat, v["mass"])))
    return v, x, x_hat


def build(cloth_cells: int, box_cells: int):
    """The scene: (scene, stepper, contact, {body: (vertices attr, faces)})."""
    s = yasps.scene("contact_demo")
    # Cloth: 1 m square at z = 0, 0.5 kg/m^2, pinned at its four corners.
    cv, cf = cloth_grid(cloth_cells, size=1.0)
    cloth_mass = np.full(len(cv), 0.5 / len(cv))
    cloth = s.addMesh("cloth")
    cloth_v, xc, xc_hat = free_vertices(cloth, cv, cloth_mass)
    add_cloth(cloth, xc, cv, cf, stretch=2e3, shear=2e2, bending=1e-3,
              scale=DT * DT)
    pinned = np.zeros(len(cv), dtype=bool)
    pinned[cloth_corners(cloth_cells)] = True
    # Soft box: 20 cm, Young's modulus 5e4, Poisson 0.4, DENSITY kg/m^3.
    bv, bt = box_tet_mesh(box_cells, size=0.2)
    faces = surface_of(bt)
    young, poisson = 5e4, 0.4
    mu = young / (2 * (1 + poisson))
    lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
    soft = s.addMesh("soft")
    soft_start = bv + [-0.3, -0.1, 0.05]
    soft_v, xs, xs_hat = free_vertices(soft, soft_start,
                                       tet_masses(bv, bt, DENSITY))
    add_elastic_tets(soft, xs, soft_start, bt, mu, lam, scale=DT * DT)
    # Affine box: the same mesh, its vertices A (rest) + t.
    rigid = s.addMesh("rigid")
    body = add_affine_body(rigid, bv - 0.1, tet_masses(bv, bt, DENSITY),
                           stiffness=1e5 * 0.2 ** 3, scale=DT * DT,
                           translation=(0.2, 0.1, 0.2))
    union = s.addMesh("all").addPrimitiveUnion("v", [cloth_v, soft_v,
                                                     body.vertices])
    union.addAttribute("position")
    n_c, n_b = len(cv), len(bv)
    contact = Contact(s, union, faces=np.concatenate(
        [cf, faces + n_c, faces + n_c + n_b]), dhat=2e-3,
        average_mass=float(np.mean(cloth_mass)), friction=0.2)
    s.addMinimizeTarget([xc, xs, body.A, body.t])
    stepper = ImplicitEuler(s, [xc, xs, body.A, body.t],
                            [xc_hat, xs_hat, body.A_hat, body.t_hat], dt=DT,
                            gravity=[GRAVITY, GRAVITY, None, GRAVITY],
                            fixed=[pinned, None, None, None], contact=contact)
    bodies = {"cloth": (xc, cf), "soft": (xs, faces),
              "rigid": (body.vertices["position"], faces)}
    return s, stepper, contact, bodies


def positions(bodies) -> Dict[str, np.ndarray]:
    """Each body's vertex positions now (the affine body's by its kernel)."""
    out = {}
    for name, (x, _) in bodies.items():
        value = x.value if x.kind != "computed" else x.compute().value
        out[name] = np.ascontiguousarray(value[:, :, 0])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=50)
    parser.add_argument("--cloth", type=int, default=40,
                        help="cloth cells per side")
    parser.add_argument("--box", type=int, default=4, help="box cells per side")
    parser.add_argument("--output", type=Path, default=Path("out/contact"))
    args = parser.parse_args()

    start = time.perf_counter()
    s, stepper, contact, bodies = build(args.cloth, args.box)
    # The first evaluation compiles every kernel (or loads them from the
    # disk cache); the time steps then compile nothing.
    contact.update()
    s.evaluateEnergy()
    s.minimizeEnergy(fixed=stepper.fixed)
    print(f"compiled or loaded the kernels in {time.perf_counter() - start:.1f} s")
    start = time.perf_counter()
    recorder = SurfaceRecorder(args.output, {k: f for k, (_, f) in bodies.items()})
    meshes = lambda P: [(P[k], bodies[k][1], COLORS[k]) for k in bodies]  # noqa: E731
    bounds = ((-0.55, -0.55, -0.35), (0.55, 0.55, 0.45))
    count = sum(len(p) for p in positions(bodies).values())
    print(f"{count} vertices: cloth {args.cloth}x{args.cloth} cells, a soft and "
          f"an affine box of {args.box}^3 cells; dt = {DT} s")
    total = NewtonReport()
    images: List[np.ndarray] = []
    stills = []
    recorder.record(0.0, positions(bodies))
    clean = True
    with tqdm(range(1, args.frames + 1), unit="frame") as progress:
        for frame in progress:
            report = stepper.step()
            total.add(report)
            P = positions(bodies)
            recorder.record(frame * DT, P)
            images.append(render_surfaces_array(meshes(P), bounds=bounds,
                                                size=(640, 480)))
            if frame in (1, args.frames // 3, 2 * args.frames // 3, args.frames):
                stills.append((frame, P))
            clean = clean and not contact.hasIntersections()
            progress.set_postfix(newton=report.iterations,
                                 pairs=sum(contact.update().values()),
                                 kappa=f"{contact.kappa:.2g}")
    wall = time.perf_counter() - start
    for frame, P in stills:
        render_surfaces(args.output / f"frame_{frame:04d}.png", meshes(P),
                        bounds=bounds, title=f"t = {frame * DT:.2f} s")
    video = write_video(args.output / "contact.mp4", images, fps=25)
    print(f"{args.frames} frames in {wall:.1f} s, {total.iterations} Newton "
          f"iterations, {sum(total.cgIterations)} CG iterations, "
          f"{'no intersections' if clean else 'INTERSECTIONS FOUND'}")
    spent = sum(total.seconds.values())
    for stage, seconds in total.seconds.items():
        print(f"  {stage:12} {seconds:7.2f} s  {100 * seconds / spent:5.1f}%")
    print(f"wrote {args.output}/*.pvd (ParaView), frame_*.png and {video.name}")
    if not clean:
        sys.exit(1)


if __name__ == "__main__":
    main()
