#!/usr/bin/env python3
"""Finds the throw that lands an affine box on a target after a bounce.

A 10 cm affine (rigid-like) box is thrown from 30 cm above the ground
towards a wall 40 cm away, bounces off it (IPC contact with two
half-spaces, no friction) and ends its flight on the ground. The target
is where a known throw puts the box's centre in the ground plane after
``--frames`` steps (the synthetic measurement); the optimisation starts
from another throw and finds an initial velocity that lands there, the
derivatives coming from the adjoint of the whole run
(``ImplicitEuler(record=True).backward``, docs/diff.md): Gauss-Newton,
one forward run and a backward pass per coordinate of the landing point
each iteration. The script prints the loss per iteration and writes a
plot of the loss and of the first and last trajectories.

    python3 examples/diff/bounce.py [--frames 60] [--iterations 30] [--output out/diff]
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import List, Tuple

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "python"))

import yasps  # noqa: E402
from yasps.contact import Contact  # noqa: E402
from yasps.sim import (ImplicitEuler, NewtonSettings,  # noqa: E402
                       add_affine_body, box_tet_mesh, lumped_masses)

DT = 0.01
#: The throw whose landing point is the target, and the first guess.
TRUE_VELOCITY = (2.2, 0.3, 1.0)
GUESS_VELOCITY = (1.6, -0.2, 1.6)
#: The wall (normal -x) and the ground (normal +z).
WALL_X = 0.4
SETTINGS = NewtonSettings(max_iterations=200, cg_tolerance=1e-12)


def build(record: bool) -> Tuple[ImplicitEuler, object]:
    """The scene and its stepper: (stepper, the body)."""
    s = yasps.scene("bounce")
    verts, tets = box_tet_mesh(1, 0.1)
    mesh = s.addMesh("box")
    body = add_affine_body(mesh, verts - 0.05, lumped_masses(verts, tets, 500.0),
                           stiffness=1e5 * 0.1 ** 3, scale=DT * DT,
                           translation=(0.0, 0.0, 0.3))
    targets = [body.A, body.t]
    s.addMinimizeTarget(targets)
    # A soft contact layer (2 cm, a low stiffness): the box bounces back
    # off the wall instead of sliding down it, as implicit Euler does on a
    # thin stiff barrier.
    contact = Contact(s, body.vertices, dhat=0.02, kappa=10.0, halfspaces=[
        ((WALL_X, 0.0, 0.0), (-1.0, 0.0, 0.0)), ((0.0, 0.0, 0.0), (0.0, 0.0, 1.0))])
    stepper = ImplicitEuler(s, targets=targets, predicted=[body.A_hat, body.t_hat],
                            dt=DT, gravity=[None, (0.0, 0.0, -9.81)],
                            contact=contact, settings=SETTINGS,
                            velocity_tolerance=1e-8, record=record)
    return stepper, body


def fly(velocity, frames: int, record: bool = False):
    """Throws the box at ``velocity``: (stepper, body, path of its centre
    (frames + 1, 3))."""
    stepper, body = build(record)
    stepper.velocities = [np.zeros((1, 3, 3)),
                          np.asarray(velocity, float).reshape(1, 3, 1)]
    path = [body.t.value[0, :, 0].copy()]
    for _ in range(frames):
        stepper.step(warn=False)
        path.append(body.t.value[0, :, 0].copy())
    return stepper, body, np.array(path)


@dataclass
class History:
    """What the optimisation went through."""
    losses: List[float] = field(default_factory=list)
    velocities: List[np.ndarray] = field(default_factory=list)
    paths: List[np.ndarray] = field(default_factory=list)
    forward_seconds: float = 0.0
    backward_seconds: float = 0.0
    #: recorded forward runs and backward passes (the timed ones)
    forward_runs: int = 0
    backward_passes: int = 0


def optimise(frames: int, iterations: int, tolerance: float = 1e-4,
             verbose: bool = True) -> Tuple[History, np.ndarray]:
    """Gauss-Newton on the landing point: the miss r(v0) is the box's
    centre in the ground plane after ``frames`` steps minus the target's,
    L = |r|^2 / 2; each iteration runs forward once and backward once per
    component of r (its Jacobian's rows), steps by -J^+ r (the least
    change of v0 that the linearised miss asks for) and halves the step
    until L falls. Stops when the miss is below ``tolerance`` (m). Returns
    the history and the target."""
    _, _, reference = fly(TRUE_VELOCITY, frames)
    target = reference[-1]
    velocity = np.array(GUESS_VELOCITY, float)
    history = History()
    for iteration in range(iterations):
        clock = time.perf_counter()
        stepper, body, path = fly(velocity, frames, record=True)
        history.forward_seconds += time.perf_counter() - clock
        history.forward_runs += 1
        miss = (path[-1] - target)[:2]
        loss = 0.5 * float(miss @ miss)
        history.losses.append(loss)
        history.velocities.append(velocity.copy())
        history.paths.append(path)
        if verbose:
            print(f"iteration {iteration:2d}: loss {loss:.3e} m^2, miss "
                  f"{1e3 * np.linalg.norm(miss):9.4f} mm, v0 = ("
                  + ", ".join(f"{v:.5f}" for v in velocity) + ") m/s")
        if np.linalg.norm(miss) < tolerance:
            break
        clock = time.perf_counter()
        rows = []
        for k in range(2):
            unit = np.zeros((1, 3, 1))
            unit[0, k, 0] = 1.0
            grads = stepper.backward({body.t: unit})
            rows.append(grads.initial_velocities[1].reshape(3))
        history.backward_seconds += time.perf_counter() - clock
        history.backward_passes += 2
        step = -np.linalg.pinv(np.array(rows)) @ miss
        # The miss is smooth between throws whose contact sets differ:
        # halve a step that does not lower the loss.
        for _ in range(20):
            _, _, trial = fly(velocity + step, frames)
            trial_miss = (trial[-1] - target)[:2]
            if float(trial_miss @ trial_miss) < 2.0 * loss:
                break
            step *= 0.5
        velocity = velocity + step
    return history, target


def plot(history: History, target: np.ndarray, path: Path) -> None:
    """The loss per iteration and the first and last trajectories (x-z)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    left.semilogy(history.losses, "o-")
    left.set_xlabel("iteration")
    left.set_ylabel("loss (m^2)")
    left.set_title("landing miss: |r|^2 / 2")
    for label, trajectory in (("first throw", history.paths[0]),
                              ("last throw", history.paths[-1])):
        right.plot(trajectory[:, 0], trajectory[:, 2], label=label)
    right.plot([target[0]], [target[2]], "k*", markersize=12, label="target")
    right.axvline(WALL_X - 0.05, color="grey", linestyle="--", label="wall (box centre's limit)")
    right.set_xlabel("x (m)")
    right.set_ylabel("z (m)")
    right.set_title("the box's centre")
    right.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--iterations", type=int, default=30)
    parser.add_argument("--output", type=Path, default=Path("out/diff"))
    args = parser.parse_args()
    history, target = optimise(args.frames, args.iterations)
    miss = np.linalg.norm((history.paths[-1][-1] - target)[:2])
    print(f"landed {1e3 * miss:.4f} mm from the target after "
          f"{len(history.losses)} runs; the throw that made the target was "
          f"{TRUE_VELOCITY}; forward {history.forward_seconds:.2f} s, backward "
          f"{history.backward_seconds:.2f} s in all")
    args.output.mkdir(parents=True, exist_ok=True)
    plot(history, target, args.output / "bounce.png")
    print(f"wrote {args.output / 'bounce.png'}")


if __name__ == "__main__":
    main()
