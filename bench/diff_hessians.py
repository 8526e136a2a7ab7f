#!/usr/bin/env python3
"""How far the adjoint's gradient moves when it solves with projected
Hessians instead of exact ones, against central differences of whole
runs, on the two examples of examples/diff at their first guesses.

The adjoint holds with the exact Hessian of each step; projected Newton
steps with each instance's Hessian PSD-projected, and an adjoint that
reused those would give another gradient. For each example: dL/dlog E of
youngs_modulus.py (a soft box dropped on a cloth) and dL/dv0 of bounce.py
(an affine box off a wall), by ``backward(hessian="exact")`` and
``backward(hessian="projected")``, and the relative error of each against
central differences (relative steps 1e-4). A third case shows what holding
friction's lags fixed costs: a soft box landing on the ground while
sliding (friction 0.3), dL/dv0 (steps 1e-4 m/s).

    python3 bench/diff_hessians.py [--json bench/results/diff_hessians.json]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

import benchlib

benchlib.use_this_checkout()
from benchlib import ROOT  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402

sys.path.insert(0, str(ROOT / "examples" / "diff"))

import bounce  # noqa: E402
import youngs_modulus as ym  # noqa: E402
import yasps.diff  # noqa: E402


def youngs_case():
    """(adjoint gradient per hessian, central differences) of L(log E)."""
    frames = 25
    _, _, _, measured = ym.drop(ym.TRUE_YOUNG, frames)
    stepper, box, (mu, lam), end = ym.drop(ym.GUESS_YOUNG, frames, record=True)
    difference = end - measured
    got = {}
    for hessian in ("exact", "projected"):
        grads = stepper.backward({box: difference}, [mu, lam], hessian=hessian)
        d_young, _ = yasps.diff.young_poisson_gradient(
            ym.GUESS_YOUNG, ym.POISSON, grads[mu], grads[lam])
        got[hessian] = np.array([d_young * ym.GUESS_YOUNG])

    def loss(log_young):
        *_, shape = ym.drop(float(np.exp(log_young)), frames)
        return 0.5 * float(((shape - measured) ** 2).sum())
    s, h = np.log(ym.GUESS_YOUNG), 1e-4
    return got, np.array([(loss(s + h) - loss(s - h)) / (2 * h)])


def bounce_case():
    """(adjoint gradient per hessian, central differences) of L(v0)."""
    frames = 60
    _, _, reference = bounce.fly(bounce.TRUE_VELOCITY, frames)
    target = reference[-1][:2]
    velocity = np.array(bounce.GUESS_VELOCITY, float)
    stepper, body, path = bounce.fly(velocity, frames, record=True)
    miss = np.zeros((1, 3, 1))
    miss[0, :2, 0] = path[-1][:2] - target
    got = {hessian: stepper.backward({body.t: miss}, hessian=hessian)
           .initial_velocities[1].reshape(3)
           for hessian in ("exact", "projected")}

    def loss(v):
        *_, trajectory = bounce.fly(v, frames)
        r = trajectory[-1][:2] - target
        return 0.5 * float(r @ r)
    want = np.zeros(3)
    for k in range(3):
        e = np.zeros(3)
        e[k] = 1e-4 * np.abs(velocity).max()
        want[k] = (loss(velocity + e) - loss(velocity - e)) / (2 * e[k])
    return got, want


def friction_case():
    """(adjoint gradient per hessian, central differences) of L(v0) for a
    soft box landing while it slides, friction's lags held fixed."""
    import yasps
    from yasps.contact import Contact
    from yasps.sim import (ImplicitEuler, NewtonSettings, add_elastic_tets,
                           add_free_vertices, box_tet_mesh)

    dt, frames = 0.01, 10
    rest, tets = box_tet_mesh(1, 0.1)
    start = rest + [0.0, 0.0, 0.0015]

    def run(velocity, record=False):
        s = yasps.scene("sliding")
        m = s.addMesh("box")
        body = add_free_vertices(m, start, 0.05)
        add_elastic_tets(m, body.x, rest, tets, 1e4, 2e4, scale=dt * dt)
        s.addMinimizeTarget([body.x])
        contact = Contact(s, body.primitive, dhat=1e-3, kappa=1e3,
                          friction=0.3, halfspaces=[((0, 0, 0), (0, 0, 1))])
        stepper = ImplicitEuler(
            s, body.x, body.x_hat, dt, contact=contact, record=record,
            settings=NewtonSettings(max_iterations=300, cg_tolerance=1e-12),
            velocity_tolerance=1e-9)
        stepper.velocities = [velocity.reshape(-1, 3, 1).copy()]
        for _ in range(frames):
            stepper.step(warn=False)
        return stepper, body.x
    velocity = np.zeros_like(start)
    velocity[:, 2], velocity[:, 0] = -0.2, 0.3
    stepper, x = run(velocity, record=True)
    w = np.random.default_rng(0).normal(size=x.value.shape)
    got = {hessian: stepper.backward({x: w}, hessian=hessian)
           .initial_velocities[0].reshape(-1)[:3]
           for hessian in ("exact", "projected")}

    def loss(v):
        _, xs = run(v)
        return float((w * xs.value).sum())
    want = np.zeros(3)
    for k in range(3):
        e = np.zeros(velocity.size)
        e[k] = 1e-4
        e = e.reshape(velocity.shape)
        want[k] = (loss(velocity + e) - loss(velocity - e)) / 2e-4
    return got, want


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_json_argument(parser, "diff_hessians")
    args = parser.parse_args()
    rows = []
    for name, case in (("youngs_modulus.py: dL/dlog E", youngs_case),
                       ("bounce.py: dL/dv0", bounce_case),
                       ("sliding with friction 0.3, lags held: dL/dv0 "
                        "(one vertex)", friction_case)):
        got, want = case()
        errors = [float(np.linalg.norm(got[h] - want) / np.linalg.norm(want))
                  for h in ("exact", "projected")]
        rows.append([name, errors[0], errors[1]])
        print(f"{name}: relative error exact {errors[0]:.2e}, projected "
              f"{errors[1]:.2e}", flush=True)
    results = Results("diff_hessians")
    results.table("errors", ["gradient", "exact Hessian", "projected Hessian"],
                  rows, ["", "{:.1e}", "{:.1e}"],
                  note="Relative error against central differences of whole "
                  "runs (relative steps 1e-4).")
    print(f"results: {results.write(args.json)}")


if __name__ == "__main__":
    main()
