#!/usr/bin/env python3
"""A soft elastic box dropped onto the ground: the first yasps simulation.

Implicit Euler with Newton's method: the energy of a step is inertia (with
gravity in the predicted positions) + stable Neo-Hookean on the tets + the
IPC log barrier between every vertex and the ground plane z = 0. yasps
differentiates, projects, assembles and solves; the Newton loop, the line
search and the step bound that keeps every vertex above the ground are a few
lines of Python (yasps.sim).

    python3 examples/drop.py [--frames 80] [--cells 4] [--output out/drop]

The frames are written as a VTU sequence (ParaView reads `frame_*.vtu`) and
a PNG shows a side view of selected frames.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

import yasps  # noqa: E402
from yasps import energies as E  # noqa: E402
from yasps.sim import ImplicitEuler, box_tet_mesh  # noqa: E402

DT = 0.01
GRAVITY = np.array([0.0, 0.0, -9.81])
DHAT = 0.02 ** 2  # squared activation distance of the ground barrier
KAPPA = 1e6       # barrier stiffness per unit of vertex mass


def build(cells: int, projection: str = "clamp", dhat: float = DHAT,
          kappa: float = KAPPA):
    """The scene: a box of ``cells``^3 cells, its target x and prediction
    x_hat. ``projection`` PSD-projects every energy (as addEnergy); ``dhat``
    (a squared distance) and ``kappa`` (per unit of vertex mass) are the
    ground barrier's (bench/accuracy_speed.py varies them)."""
    verts, tets = box_tet_mesh(cells, size=0.2)
    verts = verts + [0.0, 0.0, 0.1]   # 10 cm above the ground
    rest = verts[tets]
    dm = np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2)
    volumes = np.abs(np.linalg.det(dm)) / 6
    youngs, poisson, density = 2e4, 0.3, 1000.0
    mu = youngs / (2 * (1 + poisson))
    lam = youngs * poisson / ((1 + poisson) * (1 - 2 * poisson))
    mass = density * volumes.sum() / len(verts)

    s = yasps.scene("drop")
    box = s.addMesh("box")
    v = box.addPrimitive("vertices", numInstances=len(verts))
    t = box.addPrimitive("tets", numInstances=len(tets))
    x = v.addAttribute("x", rows=3)
    x.updateValue(verts)
    x_hat = v.addConstant("x_hat", rows=3)
    x_hat.updateValue(verts)
    t.addConstant("DmInv", rows=3, cols=3).updateValue(np.linalg.inv(dm))
    t.addConstant("volume", rows=1).updateValue(volumes[:, None])
    t2v = t.addConnectivity("t2v", v, tets, 4)
    corners = t.addAttribute("x", through=t2v, source=x)
    F = E.deformation_gradient(corners, t["DmInv"])
    s.addEnergy(t.addAttribute("elastic", computed_attribute=DT * DT *
                               E.stable_neo_hookean(F, mu, lam, t["volume"])),
                projection=projection)
    s.addEnergy(v.addAttribute("inertia", computed_attribute=E.inertia(x, x_hat, mass)),
                projection=projection)
    height2 = x[2] * x[2]
    s.addEnergy(v.addAttribute("ground", computed_attribute=DT * DT *
                               E.ipc_barrier(height2, dhat, kappa * mass)),
                projection=projection)
    s.addMinimizeTarget([x])
    return s, x, x_hat


def stay_above_ground(x: np.ndarray, p: np.ndarray) -> float:
    """The largest fraction of step p that keeps every vertex at least 10%
    of its height above the ground (a trivial CCD against a plane)."""
    z, dz = x[:, 2, 0], p[:, 2, 0]
    falling = dz < 0
    if not falling.any():
        return 1.0
    return float(min(1.0, (0.9 * z[falling] / -dz[falling]).min()))


def simulate(frames: int, cells: int, verbose: bool = True,
             on_frame=None):
    s, x, x_hat = build(cells)
    stepper = ImplicitEuler(s, x, x_hat, DT, gravity=GRAVITY,
                            velocity_tolerance=1e-2,
                            step_bound=stay_above_ground)
    history = []
    start = time.perf_counter()
    for frame in range(frames):
        report = stepper.step()
        v = stepper.velocities[0]
        lowest = float(x.value[:, 2, 0].min())
        history.append({"lowest": lowest, "speed": float(np.abs(v).max()),
                        "energies": report.energies,
                        "iterations": report.iterations})
        if on_frame is not None:
            on_frame(frame, x.value[:, :, 0])
        if verbose:
            done = int(30 * (frame + 1) / frames)
            print(f"\r[{'#' * done}{'.' * (30 - done)}] frame {frame + 1}/{frames}"
                  f"  lowest z {lowest * 100:6.2f} cm  max speed "
                  f"{history[-1]['speed']:5.2f} m/s  Newton {report.iterations}",
                  end="", flush=True)
    if verbose:
        print(f"\n{frames} frames in {time.perf_counter() - start:.1f} s")
    return history


def write_outputs(output: Path, cells: int, frames: list) -> None:
    """frame_####.vtu for ParaView and a PNG side view of some frames."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import meshio

    _, tets = box_tet_mesh(cells)
    output.mkdir(parents=True, exist_ok=True)
    for k, positions in enumerate(frames):
        meshio.write(output / f"frame_{k:04d}.vtu",
                     meshio.Mesh(positions, [("tetra", tets)]))
    picks = np.linspace(0, len(frames) - 1, 6).astype(int)
    fig, axes = plt.subplots(1, len(picks), figsize=(3 * len(picks), 3),
                             sharey=True)
    for ax, k in zip(axes, picks):
        p = frames[k]
        ax.scatter(p[:, 0], p[:, 2], s=4)
        ax.axhline(0.0, color="k", lw=1)
        ax.set_title(f"t = {k * DT:.2f} s")
        ax.set_xlim(-0.05, 0.25)
        ax.set_ylim(-0.01, 0.32)
        ax.set_aspect("equal")
    axes[0].set_ylabel("z (m)")
    fig.tight_layout()
    fig.savefig(output / "drop.png", dpi=100)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=80)
    parser.add_argument("--cells", type=int, default=4)
    parser.add_argument("--output", type=Path, default=Path("out/drop"))
    args = parser.parse_args()
    frames = []
    simulate(args.frames, args.cells,
             on_frame=lambda k, positions: frames.append(positions.copy()))
    write_outputs(args.output, args.cells, frames)
    print(f"frames: {args.output}/frame_*.vtu (ParaView), picture: "
          f"{args.output}/drop.png")


if __name__ == "__main__":
    main()
