#!/usr/bin/env python3
"""Estimates a soft box's Young's modulus from its shape after a drop.

A soft box (stable Neo-Hookean, 2^3 cells of 6 tets) is dropped
onto a cloth pinned at its corners; cloth and box are one UNION in IPC
contact. The measurement is where the box's vertices are after
``--frames`` steps with a known Young's modulus (synthetic). Starting from
another modulus, the script fits it: the loss is half the squared
distance of the box's vertices from the measured ones, its derivative
with respect to log E comes from the adjoint of the whole run
(``ImplicitEuler(record=True).backward`` with respect to the Lame
constants, chained to E by ``yasps.diff.young_poisson_gradient``;
docs/diff.md), and a safeguarded secant search finds where it vanishes.
The script prints the loss per iteration and writes a plot of the loss
and of the modulus.

    python3 examples/diff/youngs_modulus.py [--frames 25] [--iterations 20] [--output out/diff]
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
import yasps.diff  # noqa: E402
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.sim import (ImplicitEuler, NewtonSettings,  # noqa: E402
                       add_cloth, add_elastic_tets, add_free_vertices,
                       box_tet_mesh, cloth_corners, cloth_grid, lame,
                       lumped_masses)

DT = 0.01
POISSON = 0.3
#: The modulus that makes the measurement, and the first guess (Pa).
TRUE_YOUNG = 4e4
GUESS_YOUNG = 1e4
GRAVITY = np.array([0.0, 0.0, -9.81])
SETTINGS = NewtonSettings(max_iterations=200, cg_tolerance=1e-12)


def build(young: float, record: bool):
    """The scene at Young's modulus ``young``: (stepper, cloth target,
    box target, the box's Lame constants (mu, lam))."""
    s = yasps.scene("youngs_modulus")
    cv, cf = cloth_grid(6, size=0.6)
    cloth = s.addMesh("cloth")
    c = add_free_vertices(cloth, cv, lumped_masses(cv, cf, 0.3))
    add_cloth(cloth, c.x, cv, cf, stretch=1e3, shear=1e2, bending=1e-3,
              scale=DT * DT)
    pinned = np.zeros(len(cv), dtype=bool)
    pinned[cloth_corners(6)] = True
    bv, bt = box_tet_mesh(2, size=0.12)
    start = bv + [-0.06, -0.06, 0.01]
    soft = s.addMesh("soft")
    b = add_free_vertices(soft, start, lumped_masses(bv, bt, 300.0))
    mu, lam = lame(young, POISSON)
    add_elastic_tets(soft, b.x, start, bt, mu, lam, scale=DT * DT)
    union = s.addMesh("all").addPrimitiveUnion("v", [c.primitive, b.primitive])
    union.addAttribute("position")
    contact = Contact(s, union, faces=np.concatenate(
        [cf, surface_of(bt) + len(cv)]), dhat=2e-3, kappa=1e2)
    s.addMinimizeTarget([c.x, b.x])
    stepper = ImplicitEuler(s, targets=[c.x, b.x],
                            predicted=[c.x_hat, b.x_hat], dt=DT,
                            gravity=[GRAVITY, GRAVITY],
                            fixed=[pinned, None], contact=contact,
                            settings=SETTINGS, velocity_tolerance=1e-8,
                            record=record)
    return stepper, c.x, b.x, (soft["t_mu"], soft["t_lam"])


def drop(young: float, frames: int, record: bool = False):
    """The run at ``young``: (stepper, box target, Lame constants, the box's
    vertices at the end (N, 3, 1))."""
    stepper, _, box, lame_constants = build(young, record)
    stepper.velocities = [np.zeros_like(t.value) for t in stepper.targets]
    stepper.velocities[1][:, 2] = -0.5
    for _ in range(frames):
        stepper.step(warn=False)
    return stepper, box, lame_constants, box.value.copy()


@dataclass
class History:
    """What the fit went through."""
    losses: List[float] = field(default_factory=list)
    youngs: List[float] = field(default_factory=list)
    forward_seconds: float = 0.0
    backward_seconds: float = 0.0
    #: recorded forward runs and backward passes (the timed ones)
    forward_runs: int = 0
    backward_passes: int = 0


def loss_and_slope(young: float, measured: np.ndarray, frames: int,
                   history: History) -> Tuple[float, float]:
    """L(E) and dL/dlog E by one forward run and one backward pass."""
    clock = time.perf_counter()
    stepper, box, (mu, lam), end = drop(young, frames, record=True)
    history.forward_seconds += time.perf_counter() - clock
    history.forward_runs += 1
    difference = end - measured
    loss = 0.5 * float((difference ** 2).sum())
    clock = time.perf_counter()
    grads = stepper.backward({box: difference}, [mu, lam])
    history.backward_seconds += time.perf_counter() - clock
    history.backward_passes += 1
    d_young, _ = yasps.diff.young_poisson_gradient(young, POISSON, grads[mu],
                                                   grads[lam])
    return loss, d_young * young


def fit(frames: int, iterations: int, tolerance: float = 1e-4,
        verbose: bool = True) -> History:
    """A secant search for dL/dlog E = 0 from GUESS_YOUNG, kept inside the
    last bracket where the slope changed sign; stops when log E moves by
    less than ``tolerance``."""
    _, _, _, measured = drop(TRUE_YOUNG, frames)
    history = History()
    s = np.log(GUESS_YOUNG)
    previous = None
    low, high = -np.inf, np.inf
    for iteration in range(iterations):
        loss, slope = loss_and_slope(float(np.exp(s)), measured, frames, history)
        history.losses.append(loss)
        history.youngs.append(float(np.exp(s)))
        if verbose:
            print(f"iteration {iteration:2d}: E = {np.exp(s):10.1f} Pa, loss "
                  f"{loss:.4e} m^2, dL/dlog E {slope:+.3e}")
        if slope > 0:
            high = min(high, s)
        else:
            low = max(low, s)
        if previous is None or previous[1] == slope:
            step = -np.sign(slope) * 0.5          # a first move of e^0.5
        else:
            step = -slope * (s - previous[0]) / (slope - previous[1])
        nxt = s + float(np.clip(step, -1.0, 1.0))
        if not low < nxt < high:                 # outside the bracket
            nxt = 0.5 * (max(low, s - 1.0) + min(high, s + 1.0))
        previous = (s, slope)
        if abs(nxt - s) < tolerance:
            break
        s = nxt
    return history


def plot(history: History, path: Path) -> None:
    """The loss and the modulus per iteration."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    left.semilogy(history.losses, "o-")
    left.set_xlabel("iteration")
    left.set_ylabel("loss (m^2)")
    left.set_title("distance from the measured shape")
    right.semilogy(history.youngs, "o-", label="estimate")
    right.axhline(TRUE_YOUNG, color="k", linestyle="--", label="true")
    right.set_xlabel("iteration")
    right.set_ylabel("Young's modulus (Pa)")
    right.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=25)
    parser.add_argument("--iterations", type=int, default=20)
    parser.add_argument("--output", type=Path, default=Path("out/diff"))
    args = parser.parse_args()
    history = fit(args.frames, args.iterations)
    found = history.youngs[-1]
    print(f"E = {found:.1f} Pa after {len(history.losses)} runs, "
          f"{100 * (found / TRUE_YOUNG - 1):+.3f}% from the {TRUE_YOUNG:.0f} Pa "
          f"that made the measurement; forward {history.forward_seconds:.2f} s, "
          f"backward {history.backward_seconds:.2f} s in all")
    args.output.mkdir(parents=True, exist_ok=True)
    plot(history, args.output / "youngs_modulus.png")
    print(f"wrote {args.output / 'youngs_modulus.png'}")


if __name__ == "__main__":
    main()
