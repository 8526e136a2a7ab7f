#!/usr/bin/env python3
"""The paper's running example (section 4) in Python, evaluated on the CPU.

Two boxes stand in for the bunnies: a soft one whose vertex positions are
free, and an affine one whose vertices follow its body's matrix and
translation. The union of all vertices is evaluated through compiled kernels
(JOIN and UNION included), then the point-point barrier on a few pairs.
"""

import itertools
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "python"))

import yasps  # noqa: E402


def box(n: int):
    """Vertices of an (n+1)^3 grid in the unit cube."""
    return np.array(list(itertools.product(range(n + 1), repeat=3)), float) / n


def main() -> None:
    verts = box(3)
    nv = len(verts)
    s = yasps.scene("scene0")
    affine, soft = s.addMesh("bunny_affine"), s.addMesh("bunny_soft")
    affine.addPrimitive("vertices", numInstances=nv)
    affine.addPrimitive("affine_body", numInstances=1)
    A = affine.affine_body.addAttribute("affine_matrix", rows=3, cols=3)
    t = affine.affine_body.addAttribute("translation", rows=3, cols=1)
    A.updateValue(np.array([[1.0, 0.2, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.9]]))
    t.updateValue([0.0, 0.0, 1.05])
    affine.vertices.addConstant("rest_position", rows=3).updateValue(verts)
    to_body = affine.vertices.addConnectivity("to_body", affine.affine_body,
                                              [0] * nv, 1)
    jA = affine.vertices.addAttribute("affine_matrix", through=to_body, source=A)
    jt = affine.vertices.addAttribute("translation", through=to_body, source=t)
    affine.vertices.addAttribute(
        "position", computed_attribute=jA.resize(3, 3) *
        affine.vertices["rest_position"] + jt.resize(3, 1))

    soft.addPrimitive("vertices", numInstances=nv)
    soft.vertices.addAttribute("position", rows=3).updateValue(verts)

    bunnies = s.addMesh("bunnies")
    union = bunnies.addPrimitiveUnion("vertices", [affine.vertices, soft.vertices])
    union.addAttribute("position")
    bunnies.addPrimitive("pp", numInstances=0, isDynamic=True)
    pp2v = bunnies.pp.addConnectivity("pp2v", union, [], 2)
    x = bunnies.pp.addAttribute("positions", through=pp2v,
                                source=union["position"])
    dhat, kappa = 0.1, 1e3
    d = (x.row(1) - x.row(0)).dot(x.row(1) - x.row(0))
    barrier = kappa * (d - dhat) * (d - dhat) * (d / dhat).log() * (d / dhat).log()
    energy = bunnies.pp.addAttribute("point_point", computed_attribute=barrier)
    s.addEnergy(energy, dynamic_instances=True)
    s.addMinimizeTarget([soft.vertices["position"], A, t])

    positions = union["position"].compute().value[:, :, 0]
    print(f"{union.numInstances} vertices in the union; affine bottom "
          f"corner {positions[0].round(3)}, soft top corner "
          f"{positions[-1].round(3)}")

    # Collision pairs: affine bottom vertices above soft top vertices.
    affine_low = np.flatnonzero(verts[:, 2] == 0.0)
    soft_high = np.flatnonzero(verts[:, 2] == 1.0)
    pairs = np.stack([union.indexOf(affine.vertices, affine_low),
                      union.indexOf(soft.vertices, soft_high)], axis=1)
    bunnies.pp.updateNumInstances(len(pairs))
    pp2v.updateConnectivity(pairs)
    result = energy.compute()
    print(f"{len(pairs)} point-point pairs; barrier energy "
          f"{result.value.sum():.6g} (kernel from "
          f"{'memory' if result.stats['from_memory'] else 'disk' if result.stats['from_disk'] else 'a fresh compile'})")

    # Symbolic derivatives through JOIN and UNION: each pair has 24 local
    # parameters (two UNION slots of 12: an affine body's A and t, or a soft
    # vertex's 3 entries padded), projected to PSD in reduced (6x6) space.
    d = s.energyDerivatives(energy)
    real = sum(loc is not None for loc in d.locations(0))
    smallest = np.linalg.eigvalsh(d.projectedHessian).min()
    print(f"local gradients {d.gradient.shape}, Hessians {d.hessian.shape}; "
          f"pair 0 (affine-soft) has {real} real parameters; smallest "
          f"eigenvalue of the projected Hessians {smallest:.3g}")


if __name__ == "__main__":
    main()
