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


def hanging_cloth(n: int = 4, shape=None):
    """A cloth of n x n vertices pinned at its corners, sagging under its
    weight (its rest shape ``shape``, by default the flat grid it starts
    as)."""
    rest, faces = cloth_grid(n, 0.5)
    s = yasps.scene("hanging")
    m = s.addMesh("cloth")
    v = m.addPrimitive("v", numInstances=len(rest))
    x = v.addAttribute("x", rows=3)
    x.updateValue(rest)
    mass = v.addConstant("mass", rows=1)
    mass.updateValue(np.linspace(0.008, 0.012, len(rest))[:, None])
    add_cloth(m, x, rest if shape is None else shape, faces, 100.0, 50.0,
              1e-3)
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


# --- time stepping: ImplicitEuler(record=True).backward -------------------

from yasps.contact import Contact  # noqa: E402
from yasps.sim import ImplicitEuler, add_free_vertices  # noqa: E402
from yasps.sim.checkpoint import scene_state  # noqa: E402

DT = 0.01
STEP_SETTINGS = NewtonSettings(max_iterations=300, cg_tolerance=1e-12)


def swinging_cloth(record, checkpoint_every=None):
    """A cloth of 4 x 4 free vertices hanging from two pinned corners."""
    rest, faces = cloth_grid(4, 0.5)
    s = yasps.scene("swing")
    m = s.addMesh("cloth")
    body = add_free_vertices(m, rest, np.linspace(0.01, 0.02, len(rest)))
    add_cloth(m, body.x, rest, faces, 100.0, 50.0, 1e-3, scale=DT ** 2)
    s.addMinimizeTarget([body.x])
    pinned = np.zeros(len(rest), dtype=bool)
    pinned[[0, 3]] = True
    stepper = ImplicitEuler(s, body.x, body.x_hat, DT, settings=STEP_SETTINGS,
                            fixed=pinned, velocity_tolerance=1e-10,
                            record=record, checkpoint_every=checkpoint_every)
    return s, {"stretch": m["cloth_stretch"], "bending": m["cloth_bending"],
               "mass": body.primitive["mass"]}, stepper


def landing_box(record):
    """A soft box of 6 tets falling onto the ground, in contact (a fixed
    barrier stiffness) for its last steps."""
    rest, tets = box_tet_mesh(1, 0.1)
    s = yasps.scene("landing")
    m = s.addMesh("box")
    body = add_free_vertices(m, rest + [0.0, 0.0, 0.0015], 0.05)
    add_elastic_tets(m, body.x, rest, tets, 1e4, 2e4, scale=DT ** 2)
    s.addMinimizeTarget([body.x])
    contact = Contact(s, body.primitive, dhat=1e-3, kappa=1e3,
                      halfspaces=[((0, 0, 0), (0, 0, 1))])
    stepper = ImplicitEuler(s, body.x, body.x_hat, DT, settings=STEP_SETTINGS,
                            contact=contact, velocity_tolerance=1e-9,
                            record=record)
    return s, {"mu": m["t_mu"], "lam": m["t_lam"],
               "mass": body.primitive["mass"]}, stepper


def run_steps(build, record, starts, velocities, steps, change=None):
    """The run's stepper, parameters and dynamic counts after ``steps``
    steps from the targets' ``starts`` and ``velocities`` (one array per
    target), with ``change(params)`` applied first."""
    s, params, stepper = build(record)
    if change is not None:
        change(params)
    for target, start in zip(stepper.targets, starts):
        target.updateValue(start)
    stepper.velocities = [np.array(v, copy=True) for v in velocities]
    for _ in range(steps):
        stepper.step(warn=False)
    counts = {k: int(v) for k, v in scene_state(s).items()
              if k.startswith("count:")}
    return stepper, params, counts


def check_run_gradients(build, starts, velocities, steps, checks, rtol=1e-4,
                        loose=None):
    """backward's gradients against central differences of whole runs, the
    dynamic pair counts the same in every perturbed run. A check is
    (parameter name, entry, step) or ("x0" or "v0", target, entry, step).
    Every run on block-Jacobi: ``"auto"`` may pick the other preconditioner
    in a perturbed run, whose solves then differ by their tolerance."""
    with yasps.config.override(preconditioner="block-jacobi"):
        return _check_run_gradients(build, starts, velocities, steps, checks,
                                    rtol, loose or {})


def _check_run_gradients(build, starts, velocities, steps, checks, rtol,
                         loose):
    stepper, params, counts = run_steps(build, True, starts, velocities, steps)
    rng = np.random.default_rng(0)
    weights = [rng.normal(size=t.value.shape) for t in stepper.targets]
    grads = stepper.backward(dict(zip(stepper.targets, weights)),
                             list(params.values()))

    def loss(change=None, starts=starts, velocities=velocities):
        run, _, perturbed = run_steps(build, False, starts, velocities, steps,
                                      change)
        assert perturbed == counts, "the contact set changed"
        return sum(float((w * t.value).sum())
                   for w, t in zip(weights, run.targets))

    def moved(arrays, k, entry, h):
        out = [np.array(a, copy=True) for a in arrays]
        out[k].flat[entry] += h
        return out

    for check in checks:
        if check[0] in params:
            name, entry, h = check
            value = params[name].value

            def change(p, sign, name=name, entry=entry, h=h, value=value):
                shifted = value.copy()
                shifted.flat[entry] += sign * h
                p[name].updateValue(shifted)
            want = (loss(change=lambda p: change(p, 1.0)) -
                    loss(change=lambda p: change(p, -1.0))) / (2 * h)
            got = grads[params[name]].flat[entry]
        elif check[0] == "x0":
            _, k, entry, h = check
            want = (loss(starts=moved(starts, k, entry, h)) -
                    loss(starts=moved(starts, k, entry, -h))) / (2 * h)
            got = grads.initial_positions[k].flat[entry]
        else:
            _, k, entry, h = check
            want = (loss(velocities=moved(velocities, k, entry, h)) -
                    loss(velocities=moved(velocities, k, entry, -h))) / (2 * h)
            got = grads.initial_velocities[k].flat[entry]
        assert got == pytest.approx(want, rel=loose.get(check[0], rtol)), \
            (check, got, want)
    return grads, params, weights


def test_a_swinging_cloth_run_matches_differences_of_runs():
    rest, _ = cloth_grid(4, 0.5)
    start = rest[:, :, None]                       # the target's (N, 3, 1)
    velocity = np.random.default_rng(2).normal(scale=0.1, size=start.shape)
    velocity[[0, 3]] = 0.0
    check_run_gradients(swinging_cloth, [start], [velocity], 8, [
        ("stretch", 0, 1e-3), ("bending", 0, 1e-7), ("mass", 5, 1e-6),
        ("x0", 0, 17, 1e-6), ("v0", 0, 17, 1e-6), ("x0", 0, 30, 1e-6),
        ("v0", 0, 30, 1e-6),
        # A pinned vertex: it stays where it starts, pulling the cloth.
        ("x0", 0, 1, 1e-6)])


def test_a_box_landing_in_contact_matches_differences_of_runs():
    rest, _ = box_tet_mesh(1, 0.1)
    start = (rest + [0.0, 0.0, 0.0015])[:, :, None]
    velocity = np.zeros_like(start)
    velocity[:, 2] = -0.2
    _, _, counts = run_steps(landing_box, False, [start], [velocity], 10)
    assert any(counts.values()), "the box never reached the ground"
    check_run_gradients(landing_box, [start], [velocity], 10, [
        # Steps of 1e-3 of the moduli: their gradients are small against
        # the loss, and smaller steps drown in Newton's own tolerance.
        ("mu", 0, 10.0), ("lam", 0, 20.0), ("mass", 3, 1e-6),
        ("x0", 0, 16, 1e-7), ("v0", 0, 15, 1e-7), ("x0", 0, 13, 1e-7)])


def test_backward_needs_a_recording_and_refuses_predictions():
    s, params, stepper = swinging_cloth(False)
    x = stepper.targets[0]
    stepper.step(warn=False)
    with pytest.raises(yasps.SceneError, match="record=True"):
        stepper.backward({x: x.value})
    s, params, stepper = swinging_cloth(True)
    x = stepper.targets[0]
    with pytest.raises(yasps.SceneError, match="no step"):
        stepper.backward({x: x.value})
    stepper.step(warn=False)
    with pytest.raises(yasps.ArgumentError, match="prediction"):
        stepper.backward({x: x.value}, [stepper.predicted[0]])
    # The scene is left in the run's last state.
    last = x.value.copy()
    stepper.backward({x: x.value}, [params["stretch"]])
    np.testing.assert_array_equal(x.value, last)


def test_the_tape_keeps_a_constant_once():
    s, params, stepper = swinging_cloth(True)
    for _ in range(3):
        stepper.step(warn=False)
    tape = stepper.tape
    assert tape.length == 4
    kept = tape._history["value:cloth/cloth:uv_inv"][1]
    assert len(kept) == 1
    assert len(tape._history["value:cloth/v:position"][1]) == 4
    np.testing.assert_array_equal(tape.state(2)["value:cloth/cloth:uv_inv"],
                                  kept[0])


#: The soft box of four_bodies: its rest positions and tets, and its Lame
#: constants as Young's modulus and Poisson's ratio.
SOFT_REST = box_tet_mesh(1, size=0.1)[0] + [-0.2, -0.05, 0.004]
SOFT_YOUNG, SOFT_POISSON = 2e4 * (3 * 5e4 + 2 * 2e4) / (5e4 + 2e4), \
    5e4 / (2 * (5e4 + 2e4))


def four_bodies(record, rest=None):
    """A soft box, an affine box and a caged box fall onto a cloth pinned
    at its corners: free cloth vertices, free soft-body vertices, an affine
    body's A rest + t and the points a cage's trilinear cell carries, in
    one UNION, in contact (fixed stiffness, no friction) for their last
    steps."""
    from yasps.contact import surface_of
    from yasps.sim import (add_affine_body, add_caged_surface,
                           add_hex8_neo_hookean, cage_grid, cloth_corners,
                           lumped_masses)

    s = yasps.scene("four")
    cv, cf = cloth_grid(4, size=0.6)
    cloth = s.addMesh("cloth")
    c = add_free_vertices(cloth, cv, lumped_masses(cv, cf, 0.5))
    add_cloth(cloth, c.x, cv, cf, stretch=2e3, shear=2e2, bending=1e-3,
              scale=DT * DT)
    pinned = np.zeros(len(cv), dtype=bool)
    pinned[cloth_corners(4)] = True
    bv, bt = box_tet_mesh(1, size=0.1)
    faces = surface_of(bt)
    masses = lumped_masses(bv, bt, 200.0)
    soft = s.addMesh("soft")
    start = bv + [-0.2, -0.05, 0.004]
    b = add_free_vertices(soft, start, masses)
    add_elastic_tets(soft, b.x, SOFT_REST if rest is None else rest, bt,
                     2e4, 5e4, scale=DT * DT)
    rigid = s.addMesh("rigid")
    body = add_affine_body(rigid, bv - 0.05, masses,
                           stiffness=1e5 * 0.1 ** 3, scale=DT * DT,
                           translation=(0.15, 0.0, 0.054))
    # The caged box: its 8 points in one cell of a cage a little larger.
    points = bv * 0.9 + [-0.045, 0.105, 0.009]
    cage = cage_grid(points, 1, margin=0.05)
    caged = s.addMesh("caged")
    corners = add_free_vertices(caged, cage.vertices, masses.sum() / 8)
    add_hex8_neo_hookean(caged, corners.x, cage.vertices, cage.hexes, 2e4,
                         5e4, scale=DT * DT)
    surface = add_caged_surface(caged, corners.x, cage)
    union = s.addMesh("all").addPrimitiveUnion(
        "v", [c.primitive, b.primitive, body.vertices, surface])
    union.addAttribute("position")
    n_c, n_b = len(cv), len(bv)
    contact = Contact(s, union, faces=np.concatenate(
        [cf, faces + n_c, faces + n_c + n_b, faces + n_c + 2 * n_b]),
        dhat=2e-3, kappa=1e2)
    targets = [c.x, b.x, body.A, body.t, corners.x]
    s.addMinimizeTarget(targets)
    gravity = np.array([0.0, 0.0, -9.81])
    stepper = ImplicitEuler(
        s, targets=targets, predicted=[c.x_hat, b.x_hat, body.A_hat,
                                       body.t_hat, corners.x_hat], dt=DT,
        gravity=[gravity, gravity, None, gravity, gravity],
        fixed=[pinned, None, None, None, None], contact=contact,
        settings=STEP_SETTINGS, velocity_tolerance=1e-9, record=record)
    return s, {"stretch": cloth["cloth_stretch"], "mu": soft["t_mu"],
               "lam": soft["t_lam"], "rest shape": soft.t["inv"],
               "rest volume": soft.t["vol"],
               "cloth mass": c.primitive["mass"],
               "caged mu": caged["gauss_mu"]}, stepper


def test_four_bodies_in_one_union_in_contact_match_differences_of_runs():
    s, _, stepper = four_bodies(False)
    starts = [t.value for t in stepper.targets]
    velocities = [np.zeros_like(v) for v in starts]
    for k in (1, 4):
        velocities[k][:, 2] = -0.6              # the soft and caged boxes
    velocities[3][0, 2] = -0.6                  # the affine one's t
    _, _, counts = run_steps(four_bodies, False, starts, velocities, 6)
    assert any(counts.values()), "nothing touched"
    grads, params, weights = check_run_gradients(four_bodies, starts,
                                                 velocities, 6, [
        # (The affine body's orthogonality stiffness moves this loss too
        # little for differences to resolve: its gradient is 1e-6.)
        # mu by 0.5% of its 2e4: its gradient (2.6e-8) is so small that a
        # step of 20 left the difference of the losses (1e-6) to the
        # runs' Newton tolerance, which differs with the preconditioner;
        # by 1% and 2% the differences' truncation showed (1.7e-4 and
        # 3.8e-4 off on an AMD EPYC machine, whose kernels run 4 SIMD
        # lanes instead of 8).
        ("stretch", 0, 2.0), ("mu", 0, 100.0), ("lam", 0, 50.0),
        ("caged mu", 0, 20.0), ("cloth mass", 12, 1e-5),
        ("rest shape", 4, 1e-3),                # a tet's inverse rest edges
        # Positions moved by 1e-5 m, velocities by 1e-4 m/s: by less, the
        # line search's round-off shows in the differences, by more their
        # own truncation.
        ("x0", 0, 38, 1e-5),                    # a cloth vertex
        ("v0", 1, 5, 1e-4),                     # the soft box
        ("x0", 2, 4, 1e-5), ("v0", 3, 2, 1e-4),  # A, and t
        ("x0", 4, 2, 1e-5), ("v0", 4, 23, 1e-4)],  # the cage's corners
        # lam's gradient (1.6e-9) moves the loss by 1.6e-7 over the step
        # of 50 (by 2e-5 over 5e3, where the differences' truncation
        # shows): on an AMD EPYC machine (kernels in 4 SIMD lanes, not 8)
        # the runs' round-off left its differences 7.7e-3 off, checked to
        # 1e-2 here; the chain through lame below checks it too.
        loose={"lam": 1e-2})

    # Young's modulus and Poisson's ratio, and the rest positions, by the
    # chains through lame and through the tets' inverse edges and volumes.
    from functools import partial

    from yasps.sim import lame

    def loss(build=four_bodies, change=None):
        run, _, perturbed = run_steps(build, False, starts, velocities, 6,
                                      change)
        assert perturbed == counts, "the contact set changed"
        return sum(float((w * t.value).sum())
                   for w, t in zip(weights, run.targets))

    def elastic(young, poisson):
        def change(p):
            mu, lam = lame(young, poisson)
            p["mu"].updateValue([mu])
            p["lam"].updateValue([lam])
        return change
    got = yasps.diff.young_poisson_gradient(
        SOFT_YOUNG, SOFT_POISSON, grads[params["mu"]], grads[params["lam"]])
    h = 1e-3 * SOFT_YOUNG
    want = (loss(change=elastic(SOFT_YOUNG + h, SOFT_POISSON)) -
            loss(change=elastic(SOFT_YOUNG - h, SOFT_POISSON))) / (2 * h)
    assert got[0] == pytest.approx(want, rel=1e-4)
    h = 1e-3                # by less, Newton's tolerance shows
    want = (loss(change=elastic(SOFT_YOUNG, SOFT_POISSON + h)) -
            loss(change=elastic(SOFT_YOUNG, SOFT_POISSON - h))) / (2 * h)
    assert got[1] == pytest.approx(want, rel=1e-4)
    tets = box_tet_mesh(1, size=0.1)[1]
    d_rest = yasps.diff.tet_rest_gradient(
        SOFT_REST, tets, grads[params["rest shape"]],
        grads[params["rest volume"]])
    entry = int(np.argmax(np.abs(d_rest)))
    h = 1e-5
    moved = [SOFT_REST.copy(), SOFT_REST.copy()]
    moved[0].flat[entry] += h
    moved[1].flat[entry] -= h
    want = (loss(partial(four_bodies, rest=moved[0])) -
            loss(partial(four_bodies, rest=moved[1]))) / (2 * h)
    assert d_rest.flat[entry] == pytest.approx(want, rel=1e-4)


def test_young_and_poisson_gradients_follow_lame():
    from yasps.sim import lame

    for young, poisson, d_mu, d_lam in [(1e5, 0.3, 2.0, -1.0),
                                         (3e4, 0.45, -0.5, 0.25)]:
        got = yasps.diff.young_poisson_gradient(young, poisson, d_mu, d_lam)

        def loss(e, nu):
            mu, lam = lame(e, nu)
            return d_mu * mu + d_lam * lam
        h_e, h_nu = 1e-3 * young, 1e-6
        want = ((loss(young + h_e, poisson) - loss(young - h_e, poisson)) / (2 * h_e),
                (loss(young, poisson + h_nu) - loss(young, poisson - h_nu)) / (2 * h_nu))
        np.testing.assert_allclose(got, want, rtol=1e-7)
    with pytest.raises(yasps.ArgumentError):
        yasps.diff.young_poisson_gradient(1e5, 0.5, 1.0, 1.0)


def test_a_landing_box_gives_its_youngs_modulus_and_poisson_ratio():
    from yasps.sim import lame

    rest, _ = box_tet_mesh(1, 0.1)
    start = (rest + [0.0, 0.0, 0.0015])[:, :, None]
    velocity = np.zeros_like(start)
    velocity[:, 2] = -0.2
    young, poisson = 2.5e4, 0.3

    def run(e, nu, record=False):
        def change(p):
            mu, lam = lame(e, nu)
            p["mu"].updateValue([mu])
            p["lam"].updateValue([lam])
        return run_steps(landing_box, record, [start], [velocity], 10, change)

    stepper, params, counts = run(young, poisson, record=True)
    assert any(counts.values())
    w = np.random.default_rng(5).normal(size=start.shape)
    x = stepper.targets[0]
    grads = stepper.backward({x: w}, [params["mu"], params["lam"]])
    got = yasps.diff.young_poisson_gradient(
        young, poisson, grads[params["mu"]], grads[params["lam"]])

    def loss(e, nu):
        done, _, perturbed = run(e, nu)
        assert perturbed == counts
        return float((w * done.targets[0].value).sum())
    h_e, h_nu = 1e-3 * young, 1e-4
    want = ((loss(young + h_e, poisson) - loss(young - h_e, poisson)) / (2 * h_e),
            (loss(young, poisson + h_nu) - loss(young, poisson - h_nu)) / (2 * h_nu))
    np.testing.assert_allclose(got, want, rtol=1e-4)


def test_the_rest_chain_matches_differences_of_inverse_and_volume():
    rest, tets = box_tet_mesh(1, 0.1)
    rest = rest + np.random.default_rng(4).normal(scale=0.005, size=rest.shape)
    rng = np.random.default_rng(6)
    d_inv = rng.normal(size=(len(tets), 3, 3))
    d_vol = rng.normal(size=(len(tets), 1, 1))

    def loss(r):
        edges = np.stack([r[tets][:, k] - r[tets][:, 0] for k in (1, 2, 3)],
                         axis=2)
        return float((d_inv * np.linalg.inv(edges)).sum() +
                     (d_vol[:, 0, 0] * np.abs(np.linalg.det(edges)) / 6).sum())
    got = yasps.diff.tet_rest_gradient(rest, tets, d_inv, d_vol)
    want = np.zeros_like(rest)
    for i in range(rest.size):
        e = np.zeros(rest.size)
        e[i] = 1e-7
        want.flat[i] = (loss(rest + e.reshape(rest.shape)) -
                        loss(rest - e.reshape(rest.shape))) / 2e-7
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-6 * np.abs(want).max())


def test_a_compressed_box_gives_its_rest_positions():
    rest, tets = box_tet_mesh(2, 0.1)

    def build(shape):
        s = yasps.scene("rest")
        m = s.addMesh("box")
        v = m.addPrimitive("v", numInstances=len(rest))
        x = v.addAttribute("x", rows=3)
        start = rest.copy()
        start[rest[:, 2] > 0.1 - 1e-9, 2] *= 0.9
        x.updateValue(start)
        add_elastic_tets(m, x, shape, tets, 3e4, 5e4)
        s.addMinimizeTarget([x])
        held = (rest[:, 2] > 0.1 - 1e-9) | (rest[:, 2] < 1e-9)
        solve(s, x, held)
        return s, m, x, held

    s, m, x, held = build(rest)
    w = loss_weights(x)
    t = m.t
    grads = yasps.diff.equilibrium_gradient(s, {x: w}, [t["inv"], t["vol"]],
                                            fixed=[held])
    d_rest = yasps.diff.tet_rest_gradient(rest, tets, grads[t["inv"]],
                                          grads[t["vol"]])
    # The rest positions of the free vertices matter most.
    for entry in np.argsort(-np.abs(d_rest).reshape(-1))[:2]:
        h = 1e-6
        sides = []
        for sign in (1.0, -1.0):
            shape = rest.copy()
            shape.flat[entry] += sign * h
            _, _, xs, _ = build(shape)
            sides.append(float((w * xs.value).sum()))
        want = (sides[0] - sides[1]) / (2 * h)
        assert d_rest.flat[entry] == pytest.approx(want, rel=1e-4), entry


def test_projected_blocks_clamp_the_target_block_only():
    from yasps.solve.adjoint import projected_blocks

    rng = np.random.default_rng(8)
    a = rng.normal(size=(5, 4, 4))
    hessian = a + np.transpose(a, (0, 2, 1))
    index = np.array([[0, 1, 2, 9]] * 5)           # the last: a parameter
    out = projected_blocks(hessian, index, num_dofs=3)
    assert np.all(out[:, 3, :] == 0) and np.all(out[:, :, 3] == 0)
    assert np.linalg.eigvalsh(out).min() > -1e-12
    psd = a @ np.transpose(a, (0, 2, 1))
    np.testing.assert_allclose(projected_blocks(psd, np.array([[0, 1, 2, 3]] * 5), 4),
                               psd, atol=1e-12)
    s, m, x, held = compressed_box()
    solve(s, x, held)
    with pytest.raises(yasps.ArgumentError, match="exact, projected"):
        yasps.diff.equilibrium_gradient(s, {x: x.value}, [m["t_mu"]],
                                        fixed=[held], hessian="approximate")


def test_checkpoints_give_the_dense_tapes_gradients():
    rest, _ = cloth_grid(4, 0.5)
    start = rest[:, :, None]
    velocity = np.random.default_rng(2).normal(scale=0.1, size=start.shape)
    velocity[[0, 3]] = 0.0

    def run(every):
        s, params, stepper = swinging_cloth(True, every)
        stepper.targets[0].updateValue(start)
        stepper.velocities = [velocity.copy()]
        for _ in range(8):
            stepper.step(warn=False)
        x = stepper.targets[0]
        end, time = x.value.copy(), stepper.time
        w = np.random.default_rng(0).normal(size=end.shape)
        grads = stepper.backward({x: w}, list(params.values()))
        # The stepper is left where the run ended.
        np.testing.assert_array_equal(x.value, end)
        assert stepper.time == time
        return stepper.tape, grads, params
    dense, want, params = run(None)
    tape, got, other = run(3)
    assert sorted(tape.checkpoints) == [0, 3, 6] and tape.length == 0
    for a, b in zip(params.values(), other.values()):
        np.testing.assert_allclose(got[b], want[a], rtol=1e-12)
    np.testing.assert_allclose(got.initial_velocities[0],
                               want.initial_velocities[0], rtol=1e-12,
                               atol=1e-14)
    for record, every in ((False, 2), (True, 0), (True, 1.5)):
        with pytest.raises(yasps.SceneError, match="checkpoint_every"):
            swinging_cloth(record, every)


def test_the_cloth_rest_chain_matches_differences_of_its_frames():
    from yasps.sim.bodies import _triangle_rest_frames
    from yasps.sim.meshes import hinges_of

    rest, faces = cloth_grid(3, 0.5)
    rest = rest + np.random.default_rng(9).normal(scale=0.02, size=rest.shape)
    hinges = hinges_of(faces)
    rng = np.random.default_rng(10)
    d_inv = rng.normal(size=(len(faces), 2, 2))
    d_area = rng.normal(size=(len(faces), 1, 1))
    d_length = rng.normal(size=(len(hinges), 1, 1))

    def loss(r):
        inverse, areas = _triangle_rest_frames(r, faces)
        lengths = np.linalg.norm(r[hinges[:, 1]] - r[hinges[:, 0]], axis=1)
        return float((d_inv * inverse).sum() + (d_area[:, 0, 0] * areas).sum()
                     + (d_length[:, 0, 0] * lengths).sum())
    got = yasps.diff.cloth_rest_gradient(rest, faces, d_inv, d_area, d_length)
    want = np.zeros_like(rest)
    for i in range(rest.size):
        e = np.zeros(rest.size)
        e[i] = 1e-7
        want.flat[i] = (loss(rest + e.reshape(rest.shape)) -
                        loss(rest - e.reshape(rest.shape))) / 2e-7
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-6 * np.abs(want).max())


def test_a_hanging_cloth_gives_its_rest_positions():
    rest, faces = cloth_grid(4, 0.5)
    s, m, v, x, pinned = hanging_cloth()
    solve(s, x, pinned)
    w = loss_weights(x)
    tri, hinges = m.cloth, m.cloth_hinges
    grads = yasps.diff.equilibrium_gradient(
        s, {x: w}, [tri["uv_inv"], tri["area"], hinges["length"]],
        fixed=[pinned])
    d_rest = yasps.diff.cloth_rest_gradient(
        rest, faces, grads[tri["uv_inv"]], grads[tri["area"]],
        grads[hinges["length"]])
    for entry in np.argsort(-np.abs(d_rest).reshape(-1))[:2]:
        h = 1e-6
        sides = []
        for sign in (1.0, -1.0):
            shape = rest.copy()
            shape.flat[entry] += sign * h
            s2, _, _, x2, _ = hanging_cloth(shape=shape)
            solve(s2, x2, pinned)
            sides.append(float((w * x2.value).sum()))
        want = (sides[0] - sides[1]) / (2 * h)
        assert d_rest.flat[entry] == pytest.approx(want, rel=1e-4), entry
