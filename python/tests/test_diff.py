"""Gradients of equilibria with respect to the scene's constants
(yasps.diff.equilibrium_gradient): the compiler's mixed derivatives against
finite differences of the production gradient kernels, and whole gradients
against central finite differences of re-solved equilibria."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import yasps
import yasps.diff
from yasps.runtime import cpu_backend
from yasps.sim import (NewtonSettings, add_cloth, add_elastic_tets,
                       box_tet_mesh, cloth_corners, cloth_grid, newton)
from yasps.solve.adjoint import AdjointSystem, Variables, adjoint_terms

#: Tight enough that the equilibria the finite differences compare are
#: exact to well below the differences' own error.
SETTINGS = NewtonSettings(max_iterations=200, cg_tolerance=1e-12)
GRAVITY = np.array([[0.0], [0.0], [-9.81]])


def hanging_cloth(n: int = 4):
    """A cloth of n x n vertices pinned at its corners, sagging under its
    weight."""
    rest, faces = cloth_grid(n, 0.5)
    s = yasps.scene("hanging")
    m = s.addMesh("cloth")
    v = m.addPrimitive("v", numInstances=len(rest))
    x = v.addAttribute("x", rows=3)
    x.updateValue(rest)
    mass = v.addConstant("mass", rows=1)
    mass.updateValue(np.linspace(0.008, 0.012, len(rest))[:, None])
    add_cloth(m, x, rest, faces, 100.0, 50.0, 1e-3)
    s.addEnergy(v.addAttribute("weight", computed_attribute=-(
        mass * (yasps.constant(GRAVITY).T * x))))
    s.addMinimizeTarget([x])
    pinned = np.zeros(len(rest), dtype=bool)
    pinned[cloth_corners(n)] = True
    return s, m, v, x, pinned


def compressed_box():
    """A soft box of 2^3 cells on the ground, its top pressed 10% down."""
    rest, tets = box_tet_mesh(2, 0.1)
    s = yasps.scene("box")
    m = s.addMesh("box")
    v = m.addPrimitive("v", numInstances=len(rest))
    x = v.addAttribute("x", rows=3)
    start = rest.copy()
    top = rest[:, 2] > 0.1 - 1e-9
    start[top, 2] *= 0.9
    x.updateValue(start)
    add_elastic_tets(m, x, rest, tets, 3e4, 5e4)
    s.addMinimizeTarget([x])
    held = top | (rest[:, 2] < 1e-9)
    return s, m, x, held


def solve(s, x, fixed):
    newton(s, [x], 1e-12, settings=SETTINGS, fixed=[fixed])


def loss_weights(x):
    return np.random.default_rng(3).normal(size=x.value.shape)


def finite_difference(s, x, fixed, parameter, entry, w, relative=1e-4):
    """dL/dtheta of one entry of ``parameter`` for L = sum(w * x*), by
    central differences of equilibria solved from the same start."""
    start, value = x.value.copy(), parameter.value.copy()
    h = relative * max(abs(value.flat[entry]), 1e-3)
    losses = []
    for sign in (1.0, -1.0):
        moved = value.copy()
        moved.flat[entry] += sign * h
        parameter.updateValue(moved)
        x.updateValue(start)
        solve(s, x, fixed)
        losses.append(float((w * x.value).sum()))
    parameter.updateValue(value)
    x.updateValue(start)
    solve(s, x, fixed)
    return (losses[0] - losses[1]) / (2 * h)


def global_gradient(s, variables):
    """The targets' gradient, assembled from the production kernels
    (energyDerivatives), independently of the adjoint's kernels."""
    g = np.zeros(variables.num_dofs)
    for energy in s.energies:
        local = s.energyDerivatives(energy)
        dofs = local.dofs()
        keep = dofs >= 0
        g += np.bincount(dofs[keep], local.gradient[keep],
                         minlength=g.size)
    return g


def test_mixed_derivatives_match_differences_of_the_gradient():
    s, m, x, held = compressed_box()
    parameters = [m["t_mu"], m["t_lam"], m.t["inv"]]
    variables = Variables(s, parameters)
    system = AdjointSystem(variables, adjoint_terms(s, variables, cpu_backend()))
    lam = np.random.default_rng(1).normal(size=variables.num_dofs)
    mixed = system.mixed_vjp(lam)
    np.testing.assert_allclose(system.gradient, global_gradient(s, variables),
                               rtol=1e-12, atol=1e-12 * np.abs(system.gradient).max())
    checked = [(m["t_mu"], 0), (m["t_lam"], 0), (m.t["inv"], 0),
               (m.t["inv"], 40), (m.t["inv"], 7 * 9 + 4)]
    for parameter, entry in checked:
        value = parameter.value.copy()
        h = 1e-6 * max(abs(value.flat[entry]), 1.0)
        sides = []
        for sign in (1.0, -1.0):
            moved = value.copy()
            moved.flat[entry] += sign * h
            parameter.updateValue(moved)
            sides.append(lam @ global_gradient(s, variables))
        parameter.updateValue(value)
        want = (sides[0] - sides[1]) / (2 * h)
        got = variables.split(np.concatenate(
            [np.zeros(variables.num_dofs), mixed]), parameter).reshape(-1)
        # The parameter's value is (N, rows, cols), column-major per
        # instance in the variables: compare the same entry.
        got_entry = got[entry]
        assert got_entry == pytest.approx(want, rel=1e-6, abs=1e-9 * abs(want) + 1e-12), \
            (parameter.describe(), entry)


def test_a_hanging_cloth_matches_differences_of_equilibria():
    s, m, v, x, pinned = hanging_cloth()
    solve(s, x, pinned)
    w = loss_weights(x)
    parameters = [m["cloth_stretch"], m["cloth_shear"], m["cloth_bending"],
                  v["mass"]]
    grads = yasps.diff.equilibrium_gradient(s, {x: w}, parameters,
                                            fixed=[pinned])
    assert set(grads) == set(parameters)
    assert grads[v["mass"]].shape == v["mass"].value.shape
    for parameter, entry in [(m["cloth_stretch"], 0), (m["cloth_shear"], 0),
                             (m["cloth_bending"], 0), (v["mass"], 5),
                             (v["mass"], 10)]:
        want = finite_difference(s, x, pinned, parameter, entry, w)
        assert grads[parameter].flat[entry] == pytest.approx(want, rel=1e-4), \
            (parameter.describe(), entry)


def test_a_compressed_box_matches_differences_of_equilibria():
    s, m, x, held = compressed_box()
    solve(s, x, held)
    w = loss_weights(x)
    inv = m.t["inv"]
    grads = yasps.diff.equilibrium_gradient(
        s, {x: w}, [m["t_mu"], m["t_lam"], inv], fixed=[held])
    # The two entries of the rest shapes the loss depends on most (the
    # differences of the smallest are below their own error).
    largest = np.argsort(-np.abs(grads[inv]).reshape(-1))[:2]
    for parameter, entry in [(m["t_mu"], 0), (m["t_lam"], 0),
                             (inv, int(largest[0])), (inv, int(largest[1]))]:
        want = finite_difference(s, x, held, parameter, entry, w)
        assert grads[parameter].flat[entry] == pytest.approx(want, rel=1e-4), \
            (parameter.describe(), entry)


def test_fixed_dofs_do_not_move_with_the_parameters():
    s, m, x, held = compressed_box()
    solve(s, x, held)
    # A loss on the held vertices alone: they stay where they are held.
    w = np.zeros(x.value.shape)
    w[held] = 1.0
    grads = yasps.diff.equilibrium_gradient(s, {x: w}, [m["t_mu"]],
                                            fixed=[held])
    assert grads[m["t_mu"]].item() == 0.0


def test_bad_requests_are_refused_with_their_reason():
    s, m, v, x, pinned = hanging_cloth(3)
    solve(s, x, pinned)
    with pytest.raises(yasps.ArgumentError, match="minimisation target"):
        yasps.diff.equilibrium_gradient(s, {x: x.value}, [x], fixed=[pinned])
    with pytest.raises(yasps.ArgumentError, match="computed"):
        yasps.diff.equilibrium_gradient(s, {x: x.value}, [v["weight"]],
                                        fixed=[pinned])
    with pytest.raises(yasps.ArgumentError, match="listed twice"):
        yasps.diff.equilibrium_gradient(
            s, {x: x.value}, [v["mass"], v["mass"]], fixed=[pinned])
    with pytest.raises(yasps.ArgumentError, match="not a minimisation target"):
        yasps.diff.equilibrium_gradient(s, {v["mass"]: v["mass"].value},
                                        [m["cloth_stretch"]], fixed=[pinned])
    with pytest.raises(yasps.ArgumentTypeError, match="Attribute"):
        yasps.diff.equilibrium_gradient(s, {x: x.value}, ["mass"],
                                        fixed=[pinned])


def test_a_state_that_is_not_a_minimiser_is_warned_about():
    s, m, v, x, pinned = hanging_cloth(3)
    with pytest.warns(yasps.diff.AdjointWarning, match="not at a converged"):
        yasps.diff.equilibrium_gradient(s, {x: x.value}, [m["cloth_stretch"]],
                                        fixed=[pinned])
    solve(s, x, pinned)
    with warnings.catch_warnings():
        warnings.simplefilter("error", yasps.diff.AdjointWarning)
        yasps.diff.equilibrium_gradient(s, {x: x.value}, [m["cloth_stretch"]],
                                        fixed=[pinned])
