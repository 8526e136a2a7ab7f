#!/usr/bin/env python3
"""Mass-spring pendulum parameterised by angles (paper 10.7, Fig. 29).

A zigzag spring hangs from the ceiling; a lever pivots at its lower end; a
zigzag spring hangs from each end of the lever with a mass block at its
foot. The only targets are angles: each spring's zigzag angle (its length
is K l cos(phi)) and the lever's tilt. The masses' world positions are
computed attributes nested through all of them, so their inertia is a
deeply nested non-linear parameterisation; the springs' energy is k (phi -
phi_rest)^2. Implicit Euler on the masses' world positions
(``add_world_inertia``): ImplicitEuler predicts them in world space and
Newton runs over the angles; nothing is differentiated or stepped by hand.

    python3 examples/paper/pendulum.py [--frames 100] [--output DIR]
"""

from __future__ import annotations

import sys
from typing import List

import numpy as np

from common import DT, REPO, arguments  # noqa: E402

import yasps  # noqa: E402
from imageio import v3 as iio  # noqa: E402
from yasps.sim import (ImplicitEuler, NewtonReport,  # noqa: E402
                       SurfaceRecorder, add_world_inertia,
                       polyline_segments, write_video, zigzag_spring)

ANCHOR = np.array([0.0, 0.0, 0.0])
SEGMENTS, SEGMENT = 6, 0.05      # zigzag segments per spring and their length
LEVER = 0.25                     # half the lever's length
MASSES = [1.0, 0.6]              # kg, left and right block: the lever tips
STIFFNESS = 2.0                  # N m per rad^2
REST = 0.6                       # rest zigzag angle (rad)
GRAVITY = np.array([0.0, 0.0, -9.81])


def spring_length(phi):
    """End-to-end length of a zigzag spring at angle ``phi``."""
    return SEGMENTS * SEGMENT * phi.cos()


def build(name: str = "pendulum", tilt: float = 0.4):
    """The scene: (scene, parts) with targets phi (3 springs: ceiling,
    left, right) and psi (the lever), the masses' world ``position`` and
    their world-space ``inertia``."""
    s = yasps.scene(name)
    m = s.addMesh("pendulum")
    springs = m.addPrimitive("springs", numInstances=3)
    phi = springs.addAttribute("phi", rows=1)
    phi.updateValue(np.full((3, 1), REST))
    lever = m.addPrimitive("lever", numInstances=1)
    psi = lever.addAttribute("psi", rows=1)
    psi.updateValue([[tilt]])
    masses = m.addPrimitive("masses", numInstances=2)
    masses.addConstant("side", rows=1).updateValue([[-1.0], [1.0]])
    top = masses.addAttribute("phi_top", through=masses.addConnectivity(
        "to_ceiling", springs, [[0], [0]], 1), source=phi)
    own = masses.addAttribute("phi_own", through=masses.addConnectivity(
        "to_spring", springs, [[1], [2]], 1), source=phi)
    tipping = masses.addAttribute("psi", through=masses.addConnectivity(
        "to_lever", lever, [[0], [0]], 1), source=psi)
    side = masses["side"]
    # Pivot at the ceiling spring's foot, the lever's end, the block below.
    x = side * LEVER * tipping.cos()
    z = -spring_length(top) + side * LEVER * tipping.sin() - spring_length(own)
    position = masses.addAttribute("position", computed_attribute=yasps.vstack(
        [x + ANCHOR[0], 0.0 * x + ANCHOR[1], z + ANCHOR[2]]))
    inertia = add_world_inertia(position, MASSES)
    s.addEnergy(springs.addAttribute("elastic", computed_attribute=(
        DT * DT * STIFFNESS) * (phi - REST) * (phi - REST)))
    s.addMinimizeTarget([phi, psi])
    return s, dict(phi=phi, psi=psi, position=position, inertia=inertia)


def reference_positions(phi: np.ndarray, psi: float) -> np.ndarray:
    """The masses' positions from the angles, in NumPy (for the test)."""
    L = SEGMENTS * SEGMENT * np.cos(phi)
    out = []
    for side, own in ((-1.0, L[1]), (1.0, L[2])):
        out.append(ANCHOR + [side * LEVER * np.cos(psi), 0.0,
                             -L[0] + side * LEVER * np.sin(psi) - own])
    return np.array(out)


def stepper(scene, parts) -> ImplicitEuler:
    """Implicit Euler on the masses: world-space predictions and
    velocities, Newton over the angles."""
    return ImplicitEuler(scene, targets=[parts["phi"], parts["psi"]], dt=DT,
                         world=[parts["inertia"]], world_gravity=GRAVITY,
                         velocity_tolerance=1e-4)


def pendulum_lines(phi: np.ndarray, psi: float) -> np.ndarray:
    """The three springs (zigzags) and the lever's two arms as polylines in
    the x-z plane: (points, segments)."""
    top = zigzag_spring(ANCHOR, phi[0], SEGMENTS, SEGMENT)
    pivot = top[-1]
    lines = [top]
    for k, side in ((1, -1.0), (2, 1.0)):
        end = pivot + side * LEVER * np.array([np.cos(psi), 0.0, np.sin(psi)])
        lines += [np.stack([pivot, end]),
                  zigzag_spring(end, phi[k], SEGMENTS, SEGMENT)]
    points = np.concatenate(lines)
    return points, polyline_segments([len(line) for line in lines])


def draw(phi: np.ndarray, psi: float, title: str) -> np.ndarray:
    """A side view: springs coloured by stress (green to red), the lever,
    the two blocks; as an (H, W, 3) image."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    fig = Figure(figsize=(4, 5), dpi=100)
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    stress = np.abs(phi - REST) / 0.3
    colour = lambda k: (min(1.0, stress[k]), max(0.0, 1 - stress[k]), 0.2)  # noqa: E731
    points, _ = pendulum_lines(phi, psi)
    n = SEGMENTS + 1
    # The layout of pendulum_lines: spring, arm, spring, arm, spring.
    pieces = [(0, n, colour(0), 2), (n, n + 2, "0.3", 4),
              (n + 2, 2 * n + 2, colour(1), 2), (2 * n + 2, 2 * n + 4, "0.3", 4),
              (2 * n + 4, 3 * n + 4, colour(2), 2)]
    for begin, end, color, width in pieces:
        ax.plot(points[begin:end, 0], points[begin:end, 2], color=color,
                lw=width)
    for foot in (points[2 * n + 1], points[3 * n + 3]):
        ax.add_patch(Rectangle((foot[0] - 0.03, foot[2] - 0.05), 0.06, 0.05,
                               color="0.2"))
    ax.plot([-0.1, 0.1], [0, 0], color="k", lw=3)
    ax.set_xlim(-0.5, 0.5)
    ax.set_ylim(-1.0, 0.05)
    ax.set_aspect("equal")
    ax.set_title(title)
    ax.axis("off")
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[:, :, :3].copy()


def main() -> None:
    args = arguments(__doc__.split("\n")[0], frames=100)
    output = args.output or REPO / "out" / "paper" / "pendulum"
    output.mkdir(parents=True, exist_ok=True)
    scene, parts = build()
    stepping = stepper(scene, parts)
    total = NewtonReport()
    recorder = SurfaceRecorder(output, {
        "pendulum": pendulum_lines(np.full(3, REST), 0.0)[1]})
    images: List[np.ndarray] = []
    stills = {max(1, round(args.frames * k / 4)) for k in range(1, 5)}
    for frame in range(1, args.frames + 1):
        total.add(stepping.step())
        phi = parts["phi"].value[:, 0, 0]
        psi = float(parts["psi"].value[0, 0, 0])
        image = draw(phi, psi, f"t = {frame * DT:.2f} s")
        images.append(image)
        if frame in stills:
            iio.imwrite(output / f"frame_{frame:04d}.png", image)
        recorder.record(frame * DT, {"pendulum": pendulum_lines(phi, psi)[0]})
    if not args.no_video:
        write_video(output / "pendulum.mp4", images)
    print(f"pendulum: {args.frames} frames, {total.iterations} Newton "
          f"iterations, {sum(total.cg_iterations)} CG iterations")
    seconds = sum(total.seconds.values()) or 1.0
    for stage, spent in total.seconds.items():
        print(f"  {stage:12} {spent:8.2f} s  {100 * spent / seconds:5.1f}%")
    print(f"pendulum: wrote {output}")


if __name__ == "__main__":
    sys.exit(main())
