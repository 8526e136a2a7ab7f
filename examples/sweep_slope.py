#!/usr/bin/env python3
"""A soft block on a slope with friction, as a function of its parameters:
the scene of the sweep example (docs/sweeps.md).

``simulate(params)`` takes ``angle`` (degrees), ``mu`` (friction),
``youngs`` (Pa), ``steps`` (of 0.01 s), ``velocity_tolerance`` (m/s,
Newton's; default 1e-2) and ``friction_iterations`` (lags per step;
default 1) and returns how far the block's centre slid down the slope, the
closest any vertex came to the plane (by ipctk, independently of yasps)
and the block's final vertex positions.

    python3 -m yasps.sweep examples/sweep_slope.py --grid grid.json \\
        --workers 2 --output out/sweep_slope
    python3 examples/sweep_slope.py    # the docs' sweep and its plot
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any, Dict

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

import yasps  # noqa: E402
from yasps import energies as E  # noqa: E402
from yasps.contact import Contact, surface_of  # noqa: E402
from yasps.contact.halfspace import tangent_basis  # noqa: E402
from yasps.sim import ImplicitEuler, add_elastic_tets, box_tet_mesh  # noqa

DT = 0.01
DHAT = 1e-3
DENSITY = 1000.0
POISSON = 0.3


def simulate(params: Dict[str, Any]) -> Dict[str, Any]:
    """Steps the block; see the module's docstring."""
    import ipctk

    yasps.config.num_threads = 1  # the same sums in every worker
    theta = np.radians(float(params.get("angle", 30.0)))
    mu = float(params.get("mu", 0.3))
    youngs = float(params.get("youngs", 1e7))
    steps = int(params.get("steps", 20))
    lags = int(params.get("friction_iterations", 1))
    velocity_tolerance = float(params.get("velocity_tolerance", 1e-2))
    normal = np.array([-np.sin(theta), 0.0, np.cos(theta)])
    down = np.array([-np.cos(theta), 0.0, -np.sin(theta)])
    verts, tets = box_tet_mesh(1, 0.1)
    frame = np.stack([-down, [0.0, 1.0, 0.0], normal], axis=1)
    rest = verts @ frame.T + 0.5 * DHAT * normal
    s = yasps.scene("slope")
    mesh = s.addMesh("block")
    v = mesh.addPrimitive("v", numInstances=len(rest))
    x = v.addAttribute("position", rows=3)
    x.updateValue(rest)
    x_hat = v.addConstant("x_hat", rows=3)
    x_hat.updateValue(rest)
    mass = DENSITY * 0.1 ** 3 / len(rest)
    s.addEnergy(v.addAttribute("inertia", computed_attribute=E.inertia(
        x, x_hat, mass)))
    lame_mu = youngs / (2 * (1 + POISSON))
    lame_lambda = youngs * POISSON / ((1 + POISSON) * (1 - 2 * POISSON))
    add_elastic_tets(mesh, x, rest, tets, mu=lame_mu, lam=lame_lambda,
                     scale=DT * DT)
    s.addMinimizeTarget(x)
    contact = Contact(s, v, faces=surface_of(tets), dhat=DHAT,
                      average_mass=mass, halfspaces=[((0, 0, 0), normal)],
                      friction=mu, eps_v=1e-3)
    stepper = ImplicitEuler(s, x, x_hat, dt=DT, contact=contact,
                            friction_iterations=lags,
                            velocity_tolerance=velocity_tolerance)
    t0, t1 = tangent_basis(normal).T
    lowest = np.inf
    for _ in range(steps):
        stepper.step()
        lowest = min(lowest, min(
            ipctk.point_plane_signed_distance(p, np.zeros(3), t0, t1)
            for p in x.value[:, :, 0]))
    final = x.value[:, :, 0]
    return {"slid": float((final - rest).mean(axis=0) @ down),
            "lowest": float(lowest), "final": final.tolist()}


def main() -> None:
    """The docs' sweep: friction and stiffness on a 30-degree slope, its
    table and a plot of the distance slid against mu."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from yasps import sweep

    # Newton's tolerance at eps_v and 4 friction lags per step: sliding
    # follows Coulomb's law to about 1% (docs/contact.md, "Sliding
    # accuracy"); the defaults leave a stiff block far short of it.
    grid = [{"angle": 30.0, "mu": mu, "youngs": e, "steps": 30,
             "velocity_tolerance": 1e-3, "friction_iterations": 4}
            for e in (1e5, 1e7) for mu in (0.2, 0.4, 0.6, 0.8, 0.0)]
    out = Path("out/sweep_slope")
    result = sweep.run(simulate, grid, workers=2, output=out)
    fig, ax = plt.subplots(figsize=(5, 3.2))
    for e in (1e5, 1e7):
        rows = sorted((r for r in result.rows if r["params"]["youngs"] == e
                       and r["status"] == "ok"),
                      key=lambda r: r["params"]["mu"])
        ax.plot([r["params"]["mu"] for r in rows],
                [100 * r["outputs"]["slid"] for r in rows], "o-",
                label=f"E = {e:.0e} Pa")
    mus = np.linspace(0.0, np.tan(np.radians(30.0)), 50)
    # Implicit Euler's distance in N steps at the Coulomb acceleration.
    n = 30
    free = 0.5 * 9.81 * (np.sin(np.radians(30.0)) - mus *
                         np.cos(np.radians(30.0))) * DT * DT * n * (n + 1)
    ax.plot(mus, 100 * free, "k--", lw=1,
            label="g (sin - mu cos) dt^2 N (N + 1) / 2")
    ax.set_xlabel("friction coefficient mu")
    ax.set_ylabel("slid in 0.3 s (cm)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    picture = Path(__file__).resolve().parents[1] / "docs" / "sweeps" / \
        "slope.png"
    picture.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(picture, dpi=120)
    for r in result.rows:
        print(f"mu {r['params']['mu']:.1f}  E {r['params']['youngs']:.0e}  "
              f"{r['status']:7} slid {100 * r['outputs'].get('slid', 0):6.2f}"
              f" cm  lowest {r['outputs'].get('lowest', 0):.2e} m  "
              f"Newton {r['newton_iterations']:4}  CG "
              f"{r['cg_iterations']:5}  kernels {r['kernels_compiled']:3}  "
              f"{r['seconds']:.1f} s")
    print(f"picture: {picture}")


if __name__ == "__main__":
    main()
