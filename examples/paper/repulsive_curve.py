#!/usr/bin/env python3
"""Repulsive curve on the bunny (paper 9.5, Fig. 18).

1. The bunny's surface is mapped onto the unit sphere. It is smoothed
   continuously until it is a sphere (yasps.sim.smooth_to_sphere), then
   relaxed by energy minimisation with yasps. The energies are
   Baraff-Witkin against the bunny's own triangles (scaled to the sphere's
   area) and the paper's bending l0 |N1 - N2|^2. Barriers on each
   triangle's signed volume about the centre keep the map one-to-one.
   Every vertex is parameterised on the sphere as u / |u|.
2. The density rho = A_bunny / A_sphere of each triangle is averaged at
   its vertices and interpolated over the sphere.
3. A closed curve of points u / |u| on the sphere repulses itself. Its
   energies are IPC barriers between its edges (yasps.contact on the
   curve's edges), an inverse-length penalty per edge and a light bending,
   with a damping inertia whose mass is the density under each point:
   where the bunny's triangles were shrunk most (its ears), the curve moves
   least.
4. Mapped back through the same barycentric coordinates, the curve lies on
   the bunny.

    python3 examples/paper/repulsive_curve.py [--frames 60] [--scale small|paper]
        [--output DIR]
"""

from __future__ import annotations

import sys
import time
from types import SimpleNamespace

import numpy as np

from common import REPO, arguments, bunny  # noqa: E402

import yasps  # noqa: E402
from yasps import energies as E  # noqa: E402
from yasps.contact import Contact  # noqa: E402
from yasps.sim import (NewtonReport, NewtonSettings,  # noqa: E402
                       SurfaceRecorder, add_cloth, newton, render_surfaces,
                       render_surfaces_array, tube_mesh, write_video)
from yasps.sim.sphere import (SphereMap, smooth_to_sphere,  # noqa: E402
                              triangle_areas, triangle_orientations)

POINTS = {"small": 48, "paper": 160}   # points on the curve
DHAT = 0.12                            # repulsion distance on the unit sphere
RELAX_ITERATIONS = 8
GROWTH = 1e-4                          # inverse-length penalty per edge
BENDING = 5e-2                         # discrete bending of the curve
KAPPA = 1e-2                           # barrier stiffness


def on_sphere(u):
    """A point u / |u| of the unit sphere, for a 3x1 attribute u."""
    return u / u.norm()


def surface(scale: str):
    """The bunny's surface: (vertices (N, 3), outward triangles)."""
    verts, _, faces = bunny(scale, 1.0)
    used = np.unique(faces)
    index = -np.ones(len(verts), dtype=np.int64)
    index[used] = np.arange(len(used))
    return verts[used], index[faces]


def relax_sphere(verts: np.ndarray, faces: np.ndarray, start: np.ndarray,
                 report: NewtonReport) -> np.ndarray:
    """Stage 1's energy minimisation from ``start`` (unit positions):
    returns the relaxed unit positions."""
    s = yasps.scene("sphere_map")
    mesh = s.addMesh("sphere")
    v = mesh.addPrimitive("v", numInstances=len(verts))
    u = v.addAttribute("u", rows=3)
    u.updateValue(start)
    position = v.addAttribute("position", computed_attribute=on_sphere(u))
    # The bunny's triangles at the sphere's area: what Baraff-Witkin keeps.
    rest = verts * np.sqrt(4 * np.pi / triangle_areas(verts, faces).sum())
    add_cloth(mesh, position, rest, faces, stretch=1.0, shear=1.0,
              bending=1e-2)
    tri = mesh.addPrimitive("orientation", numInstances=len(faces))
    reference = triangle_orientations(start, faces)
    tri.addConstant("start", rows=1).updateValue(reference[:, None])
    c = tri.addAttribute("c", through=tri.addConnectivity(
        "o2v", v, faces, 3), source=position)
    volume = c.row(0).T.dot(c.row(1).T.cross(c.row(2).T)) / tri["start"]
    s.addEnergy(tri.addAttribute("barrier", computed_attribute=
                                 E.ipc_barrier(volume, 0.5, 1e-3)))
    # Keeps |u| at 1 (the map ignores it).
    s.addEnergy(v.addAttribute("gauge", computed_attribute=
                               1e-3 * (u.squaredNorm() - 1.0) * (u.squaredNorm() - 1.0)))
    s.addMinimizeTarget(u)

    def keep_orientation(x, p):
        # The largest of 1, 1/2, ... along which no triangle turns inwards.
        alpha = 1.0
        while alpha > 1e-6:
            moved = x[:, :, 0] + alpha * p[:, :, 0]
            moved /= np.linalg.norm(moved, axis=1, keepdims=True)
            if (triangle_orientations(moved, faces) > 0).all():
                return alpha
            alpha *= 0.5
        return 0.0

    # Compiled (or loaded) before the timed iterations, as common.run does.
    s.evaluateEnergy()
    s.minimizeEnergy()
    report.add(newton(s, u, tolerance=1e-6, step_bound=keep_orientation,
                      settings=NewtonSettings(max_iterations=RELAX_ITERATIONS,
                                              cg_tolerance=1e-6)))
    out = u.value[:, :, 0]
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def sphere_map(scale: str, report: NewtonReport) -> SphereMap:
    """Stages 1 and 2."""
    verts, faces = surface(scale)
    start = smooth_to_sphere(verts, faces)
    return SphereMap(relax_sphere(verts, faces, start, report), faces, verts)


def start_curve(count: int) -> np.ndarray:
    """A small circle of ``count`` points on the unit sphere."""
    angle = 2 * np.pi * np.arange(count) / count
    axis = np.array([0.3, -0.9, 0.3]) / np.linalg.norm([0.3, -0.9, 0.3])
    a = np.cross(axis, [0.0, 0.0, 1.0])
    a /= np.linalg.norm(a)
    b = np.cross(axis, a)
    points = np.cos(0.35) * axis + np.sin(0.35) * (
        np.cos(angle)[:, None] * a + np.sin(angle)[:, None] * b)
    return points / np.linalg.norm(points, axis=1, keepdims=True)


class Curve:
    """Stage 3: the repulsive curve on the sphere."""

    def __init__(self, count: int, density):
        self.density = density
        s = yasps.scene("repulsive_curve")
        mesh = s.addMesh("curve")
        p = mesh.addPrimitive("p", numInstances=count)
        self.u = p.addAttribute("u", rows=3)
        self.u.updateValue(start_curve(count))
        self.position = p.addAttribute("position",
                                       computed_attribute=on_sphere(self.u))
        self.previous = p.addConstant("previous", rows=3)
        self.mass = p.addConstant("mass", rows=1)
        s.addEnergy(p.addAttribute("damping", computed_attribute=E.inertia(
            self.position, self.previous, self.mass)))
        s.addEnergy(p.addAttribute("gauge", computed_attribute=
                                   1e-4 * (self.u.squaredNorm() - 1.0)
                                   * (self.u.squaredNorm() - 1.0)))
        self.edges = np.stack([np.arange(count),
                               (np.arange(count) + 1) % count], 1)
        e = mesh.addPrimitive("e", numInstances=count)
        ends = e.addAttribute("ends", through=e.addConnectivity(
            "e2p", p, self.edges, 2), source=self.position)
        length = (ends.row(1) - ends.row(0)).norm()
        s.addEnergy(e.addAttribute("inverse_length",
                                   computed_attribute=GROWTH / length))
        triples = np.stack([(np.arange(count) - 1) % count, np.arange(count),
                            (np.arange(count) + 1) % count], 1)
        b = mesh.addPrimitive("b", numInstances=count)
        k = b.addAttribute("k", through=b.addConnectivity(
            "b2p", p, triples, 3), source=self.position)
        s.addEnergy(b.addAttribute("bending", computed_attribute=BENDING * (
            k.row(0) - 2.0 * k.row(1) + k.row(2)).squaredNorm()))
        s.addMinimizeTarget(self.u)
        self.contact = Contact(s, p, edges=self.edges, dhat=DHAT, kappa=KAPPA)
        self.scene = s

    def points(self) -> np.ndarray:
        return self.position.compute().value[:, :, 0]

    def length(self) -> float:
        P = self.points()
        return float(np.linalg.norm(P[self.edges[:, 1]] - P[self.edges[:, 0]],
                                    axis=1).sum())

    def prepare(self) -> None:
        """The damping's anchor and masses at the points now."""
        P = self.points()
        self.previous.updateValue(P)
        self.mass.updateValue(self.density(P)[:, None])

    def step(self) -> NewtonReport:
        """One step of the damped flow: mass from the density under each
        point, then Newton from here."""
        self.prepare()
        report = newton(self.scene, self.u, tolerance=1e-5,
                        contact=self.contact, settings=NewtonSettings(
                            max_iterations=20, cg_tolerance=1e-6))
        value = self.u.value[:, :, 0]
        self.u.updateValue(value / np.linalg.norm(value, axis=1,
                                                  keepdims=True))
        return report


def simulate_curve(args) -> SimpleNamespace:
    """Stages 1-4 for ``args.frames`` steps into ``args.output``: the
    summary (frames, report, seconds, min_distance, intersections, files,
    lengths, the curve's positions after each step) that the gallery reads
    too."""
    output = args.output or REPO / "out" / "paper" / "repulsive_curve"
    output.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    total = NewtonReport()
    mapping = sphere_map(args.scale, total)
    print(f"repulsive_curve: sphere map of {len(mapping.sphere)} vertices in "
          f"{time.perf_counter() - start:.1f} s ({total.iterations} Newton "
          f"iterations)")
    # The density relative to its median: unit mass where the map keeps
    # areas typical.
    median = np.median(mapping.vertex_density())
    curve = Curve(POINTS[args.scale],
                  lambda P: mapping.density_at(P) / median)
    lengths = [curve.length()]
    curve.prepare()
    curve.contact.update()
    curve.scene.evaluateEnergy()
    curve.scene.minimizeEnergy()
    centre = mapping.surface.mean(axis=0)
    size = 1.3 / np.abs(mapping.surface - centre).max()
    offset = np.array([2.6, 0.0, 0.0])

    def drawn(P):
        """The bunny with the curve mapped onto it, the sphere beside it."""
        on_bunny = (mapping.to_surface(P) - centre) * size
        return [((mapping.surface - centre) * size, mapping.faces,
                 (0.85, 0.75, 0.6)),
                (*tube_mesh(on_bunny, 0.012), (0.8, 0.1, 0.1)),
                (mapping.sphere * 0.98 + offset, mapping.faces,
                 (0.7, 0.75, 0.85)),
                (*tube_mesh(P + offset, 0.015), (0.8, 0.1, 0.1))], on_bunny

    recorder = SurfaceRecorder(output, {"curve": curve.edges,
                                        "on_bunny": curve.edges})
    images, closest, files, history = [], np.inf, {}, []
    stills = {max(1, round(args.frames * k / 4)) for k in range(1, 5)}
    bounds = ((-1.4, -1.4, -1.4), (3.9, 1.4, 1.4))
    for frame in range(1, args.frames + 1):
        total.add(curve.step())
        P = curve.points()
        history.append(P)
        lengths.append(curve.length())
        closest = min(closest, curve.contact.min_distance())
        meshes, on_bunny = drawn(P)
        recorder.record(float(frame), {"curve": P, "on_bunny": on_bunny})
        if not args.no_video:
            images.append(render_surfaces_array(meshes, bounds=bounds))
        if frame in stills:
            files[f"frame_{frame}"] = render_surfaces(
                output / f"frame_{frame:04d}.png", meshes, bounds=bounds,
                title=f"step {frame}")
    if images:
        files["video"] = write_video(output / "contact.mp4", images, fps=15)
    return SimpleNamespace(frames=args.frames, report=total,
                           seconds=time.perf_counter() - start,
                           min_distance=closest,
                           # The curve crosses itself only through distance 0.
                           intersections=not closest > 0, files=files,
                           lengths=lengths, positions=history,
                           mapping=mapping, curve=curve)


def main() -> None:
    args = arguments(__doc__.split("\n")[0], frames=60)
    summary = simulate_curve(args)
    r = summary.report
    print(f"repulsive_curve: {summary.frames} frames in {summary.seconds:.1f} "
          f"s, {r.iterations} Newton iterations, {sum(r.cg_iterations)} CG "
          f"iterations, min distance {summary.min_distance:.3g}, length "
          f"{summary.lengths[0]:.2f} -> {summary.lengths[-1]:.2f}")
    seconds = sum(r.seconds.values()) or 1.0
    for stage, spent in r.seconds.items():
        print(f"  {stage:12} {spent:8.2f} s  {100 * spent / seconds:5.1f}%")
    print(f"repulsive_curve: wrote {args.output or REPO / 'out' / 'paper' / 'repulsive_curve'}")
    sys.exit(1 if summary.intersections else 0)


if __name__ == "__main__":
    main()
