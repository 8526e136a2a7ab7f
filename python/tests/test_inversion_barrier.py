"""Stable Neo-Hookean made inversion-free (``guard_inversion=True``): the
barrier it then gets on J = det F equals its formula written here in NumPy
(zero above a tenth of the rest volume), its gradient equals central
differences, and a soft box crushed by its prescribed top far faster than
it can give converges every step with every tet positive, where the step
bound alone stalled (steps cut to nothing at a collapsing tet) and the
material alone inverts."""

import numpy as np
import pytest

import yasps
from yasps.sim import add_elastic_tets, lame

from test_inversion import crushed_box

REST = np.array([[0.0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, 0.1]])
MU, LAM = lame(1e4, 0.4)


def snh_with_barrier(x: np.ndarray) -> float:
    """Stable Neo-Hookean (Smith et al. 2018) plus the barrier, NumPy."""
    rest = (REST[1:] - REST[0]).T
    F = (x[1:] - x[0]).T @ np.linalg.inv(rest)
    ic, J = (F * F).sum(), np.linalg.det(F)
    alpha = 1 + 0.75 * MU / LAM
    psi = 0.5 * MU * (ic - 3) - 0.5 * MU * np.log(ic + 1) \
        + 0.5 * LAM * (J - alpha) ** 2
    s = J / 0.1
    if s < 1:
        psi += -(MU + LAM) * (s - 1) ** 2 * np.log(s)
    return abs(np.linalg.det(rest)) / 6 * psi


def one_tet(x: np.ndarray):
    s = yasps.scene("inversion_barrier")
    mesh = s.addMesh("m")
    v = mesh.addPrimitive("v", numInstances=4)
    pos = v.addAttribute("x", rows=3)
    pos.updateValue(x)
    energy = add_elastic_tets(mesh, pos, REST, np.array([[0, 1, 2, 3]]),
                              MU, LAM, guard_inversion=True)
    s.addMinimizeTarget(pos)
    return s, pos, energy


@pytest.mark.parametrize("squash", [0.5, 0.08, 0.01, 1e-4])
def test_the_barrier_is_its_formula_and_its_gradient_differences(squash):
    """Squashed along z to ``squash`` of its height, sheared a little: above
    J = 0.1 the energy is stable Neo-Hookean's alone."""
    x = REST.copy()
    x[:, 2] *= squash
    x[:, 0] += 0.3 * x[:, 2]
    s, pos, energy = one_tet(x)
    want = snh_with_barrier(x)
    assert s.evaluateEnergy() == pytest.approx(want, rel=1e-12)
    d = s.energyDerivatives(energy)
    h = 1e-7 * squash
    fd = np.zeros(12)
    for k in range(12):
        for sign in (1, -1):
            moved = x.copy()
            moved[k // 3, k % 3] += sign * h
            fd[k] += sign * snh_with_barrier(moved) / (2 * h)
    # The kernel's local parameters: the tet's four corners, x y z each.
    assert np.abs(d.gradient[0] - fd).max() <= 1e-6 * np.abs(fd).max()


def test_an_inverted_tet_has_no_finite_energy():
    x = REST.copy()
    x[3, 2] = -0.01
    s, *_ = one_tet(x)
    assert not np.isfinite(s.evaluateEnergy())


def test_a_crushed_guarded_stable_neo_hookean_box_never_inverts():
    smallest, lag = crushed_box("stable_neo_hookean", guard=True)
    assert 0.0 < smallest < 0.5
    assert lag > 0.1  # the top could not follow: it would have inverted
