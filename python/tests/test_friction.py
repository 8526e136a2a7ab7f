"""Friction and half-spaces of yasps.contact: the lagged friction equals
ipctk's FrictionPotential on the same tangential set; the half-space
barrier, its CCD and its friction equal ipctk's point-plane functions and a
vertex-triangle pair on a large static triangle; a block on a slope sticks
below the friction angle and slides above it, and with lagged friction
iterations slides as far as implicit Euler under Coulomb's law, every frame
checked against the plane by ipctk; Newton's stopping rule measures the
whole direction, not a step that CCD cut short."""

import ipctk
import numpy as np
import pytest

import yasps
from yasps import SceneError
from yasps import energies as E
from yasps import sim
from yasps.contact import Contact, surface_of
from yasps.contact.halfspace import tangent_basis
from yasps.sim import ImplicitEuler, add_elastic_tets, box_tet_mesh

from conftest import ipctk_collisions
from test_contact import relative, rotation, system_arrays, two_soft_boxes

NONE = ipctk.PSDProjectionMethod.NONE


def test_friction_matches_ipctk():
    """Two soft boxes within dhat, friction lagged at their start, then the
    upper box moved tangentially by nothing, less than eps_u and more:
    energy, gradient and Hessian (barrier + friction) equal ipctk's
    BarrierPotential + FrictionPotential on displacements."""
    verts, tets = box_tet_mesh(2, 0.5)
    faces = surface_of(tets)
    turned = (verts - 0.25) @ rotation(0.3, [1, 2, 0.5]).T + 0.25
    start = turned + [0.1, 0.05, 0.5 - turned[:, 2].min() + 0.02]
    s, _, (xa, xb), union = two_soft_boxes("friction", verts, start)
    dt, mu, eps_v, dhat, kappa = 0.01, 0.3, 0.1, 0.05, 3.0
    contact = Contact(s, union, faces=np.concatenate([faces, faces + len(verts)]),
                      dhat=dhat, kappa=kappa, projection="none",
                      friction=mu, eps_v=eps_v)
    s.addMinimizeTarget([xa, xb])
    counts = contact.update(lag=True, dt=dt)
    assert sum(counts[f"friction{k}"] for k in (2, 3, 4)) > 0
    Vt = contact.world()
    lagged = ipctk.NormalCollisions()
    lagged.build(contact.mesh, Vt, dhat)
    barrier = ipctk.BarrierPotential(dhat, kappa)
    tangential = ipctk.TangentialCollisions()
    tangential.build(contact.mesh, Vt, lagged, barrier, mu)
    friction = ipctk.FrictionPotential(eps_v * dt)
    rng = np.random.default_rng(0)
    for scale in (0.0, 1e-4, 3e-3):
        xb.updateValue(start + scale * rng.standard_normal(start.shape))
        contact.update()
        V = contact.world()
        U = V - Vt
        collisions = ipctk_collisions(contact, V)
        want = friction(tangential, contact.mesh, U) + \
            barrier(collisions, contact.mesh, V)
        assert abs(s.evaluateEnergy() - want) <= 1e-10 * abs(want)
        g, H = system_arrays(s)
        assert relative(g, friction.gradient(tangential, contact.mesh, U)
                        + barrier.gradient(collisions, contact.mesh,
                                           V)) < 1e-10
        reference = friction.hessian(tangential, contact.mesh, U,
                                     project_hessian_to_psd=NONE) + \
            barrier.hessian(collisions, contact.mesh, V,
                            project_hessian_to_psd=NONE)
        assert relative(H, reference.toarray()) < 1e-10


def single_vertices(name: str, points: np.ndarray):
    """A scene of free vertices at ``points``: (scene, primitive, x)."""
    s = yasps.scene(name)
    v = s.addMesh("m").addPrimitive("v", numInstances=len(points))
    x = v.addAttribute("position", rows=3)
    x.updateValue(points)
    s.addMinimizeTarget(x)
    return s, v, x


def test_halfspace_barrier_matches_ipctk_point_plane():
    """Vertices above a tilted plane: the barrier's energy, gradient and
    Hessian equal ipctk's barrier on ipctk's point-plane distance, its
    gradient and Hessian (chain rule); vertices beyond dhat add nothing."""
    origin, normal = np.array([0.1, -0.2, 0.3]), np.array([0.3, -0.2, 1.0])
    n = normal / np.linalg.norm(normal)
    heights = np.array([2e-3, 5e-3, 9e-3, 2e-2])
    lateral = np.array([[0.1, 0.2, 0.0], [-0.3, 0.1, 0.0], [0.2, -0.4, 0.0],
                        [0.0, 0.0, 0.0]]) @ tangent_basis(n) @ tangent_basis(n).T
    points = origin + lateral + heights[:, None] * n
    s, v, x = single_vertices("plane", points)
    dhat, kappa = 1e-2, 2.0
    contact = Contact(s, v, dhat=dhat, kappa=kappa, projection="none",
                      halfspaces=[(origin, normal)])
    assert contact.update()["plane"] == 3
    energy, grad, hess = 0.0, np.zeros(12), np.zeros((12, 12))
    for k, p in enumerate(points[:3]):
        d = ipctk.point_plane_distance(p, origin, n)
        dd = ipctk.point_plane_distance_gradient(p, origin, n).reshape(3)
        d2 = ipctk.point_plane_distance_hessian(p, origin, n)
        b1 = ipctk.barrier_first_derivative(d, dhat * dhat)
        energy += kappa * ipctk.barrier(d, dhat * dhat)
        grad[3 * k:3 * k + 3] = kappa * b1 * dd
        hess[3 * k:3 * k + 3, 3 * k:3 * k + 3] = kappa * (
            ipctk.barrier_second_derivative(d, dhat * dhat) * np.outer(dd, dd)
            + b1 * d2)
    assert abs(s.evaluateEnergy() - energy) <= 1e-12 * abs(energy)
    g, H = system_arrays(s)
    assert relative(g, grad) < 1e-12
    assert relative(H, hess) < 1e-12
    assert contact.min_distance() == pytest.approx(heights[0], rel=1e-12)


def test_halfspace_step_bound_matches_ipctk_ccd():
    """The half-space's step bound is ipctk's point_static_plane_ccd (same
    conservative rescaling) of the first vertex to reach the plane; a step
    that stays above it is whole; a vertex below is an intersection."""
    origin, normal = np.zeros(3), np.array([0.0, 0.2, 1.0])
    rng = np.random.default_rng(3)
    points = rng.uniform(-1, 1, (6, 3))
    points[:, 2] = rng.uniform(0.05, 0.5, 6) + 0.2 * np.abs(points[:, 1])
    s, v, x = single_vertices("ccd", points)
    contact = Contact(s, v, dhat=1e-3, kappa=1.0,
                      halfspaces=[(origin, normal)])
    step = rng.uniform(-0.2, 0.2, (6, 3, 1))
    step[:, 2] -= 0.6
    impacts = []
    for p, q in zip(points, points + step[:, :, 0]):
        hit, toi = ipctk.point_static_plane_ccd(p, q, origin, normal /
                                                np.linalg.norm(normal))
        impacts.append(toi if hit else 1.0)
    assert min(impacts) < 1.0
    assert contact.step_bound([step]) == pytest.approx(min(impacts), rel=1e-12)
    assert contact.step_bound([np.abs(step)]) == 1.0
    assert not contact.has_intersections()
    x.updateValue(points + step[:, :, 0])
    assert contact.has_intersections()


def test_halfspace_friction_equals_a_static_triangle():
    """A vertex moving over a ground plane has the friction of the same
    vertex over a large static triangle in that plane (ipctk's
    vertex-triangle FrictionPotential): friction pairs of half-spaces get
    ipctk's normal force and a basis of the plane."""
    dhat, kappa, mu, eps_v, dt = 1e-2, 5.0, 0.4, 0.05, 0.01
    p0 = np.array([[0.1, -0.05, 4e-3]])
    s, v, x = single_vertices("ground", p0)
    contact = Contact(s, v, dhat=dhat, kappa=kappa, projection="none",
                      halfspaces=[((0, 0, 0), (0, 0, 1))], friction=mu,
                      eps_v=eps_v)
    assert contact.update(lag=True, dt=dt)["friction1"] == 1
    big = np.array([[-10.0, -10.0, 0.0], [10.0, -10.0, 0.0], [0.0, 10.0, 0.0]])
    V0 = np.vstack([p0, big])
    mesh = ipctk.CollisionMesh(V0, ipctk.edges(np.array([[1, 2, 3]])),
                               np.array([[1, 2, 3]], dtype=np.int32))
    # Only the vertex-triangle pair: the triangle's own corners are far.
    collisions = ipctk.NormalCollisions()
    collisions.build(mesh, V0, dhat)
    assert len(collisions) == 1 and collisions.is_face_vertex(0)
    tangential = ipctk.TangentialCollisions()
    tangential.build(mesh, V0, collisions, ipctk.BarrierPotential(dhat, kappa),
                     mu)
    friction = ipctk.FrictionPotential(eps_v * dt)
    for shift in ([0.0, 0.0, 0.0], [2e-4, -1e-4, 1e-4], [3e-3, 1e-3, -5e-4]):
        p = p0 + shift
        x.updateValue(p)
        contact.update()
        U = np.vstack([p, big]) - V0
        barrier_only = kappa * ipctk.barrier(float(p[0, 2]) ** 2, dhat * dhat)
        want = friction(tangential, mesh, U)
        assert abs(s.evaluateEnergy() - barrier_only - want) <= \
            1e-10 * max(want, 1e-300) + 1e-14 * barrier_only
        g, H = system_arrays(s)
        fg = friction.gradient(tangential, mesh, U)[:3]
        fH = friction.hessian(tangential, mesh, U,
                              project_hessian_to_psd=NONE).toarray()[:3, :3]
        # The plane's barrier acts along z only: compare the tangential rows.
        assert relative(g[:2], fg[:2]) < 1e-10
        assert relative(H[:2, :2], fH[:2, :2]) < 1e-10


def block_on_slope(angle_degrees: float, mu: float, steps: int,
                   on_report=None, ground_mu=None, **stepping):
    """A stiff soft block resting on a slope of ``angle_degrees`` with
    friction ``mu``, stepped by implicit Euler (``stepping``: more of its
    options; ``on_report``: called with each step's report): the distance
    its centre slid down the slope, and the smallest height of a vertex
    above the plane in any frame (by ipctk's point-plane distance).
    ``ground_mu``: the block-slope pair's own coefficient, if given."""
    theta = np.radians(angle_degrees)
    normal = np.array([-np.sin(theta), 0.0, np.cos(theta)])
    down = np.array([-np.cos(theta), 0.0, -np.sin(theta)])
    verts, tets = box_tet_mesh(1, 0.1)
    frame = np.stack([-down, [0.0, 1.0, 0.0], normal], axis=1)
    dhat, dt = 1e-3, 0.01
    rest = verts @ frame.T + 0.5 * dhat * normal
    s = yasps.scene(f"slope{int(angle_degrees)}")
    mesh = s.addMesh("block")
    v = mesh.addPrimitive("v", numInstances=len(rest))
    x = v.addAttribute("position", rows=3)
    x.updateValue(rest)
    x_hat = v.addConstant("x_hat", rows=3)
    x_hat.updateValue(rest)
    mass = 1000.0 * 0.1 ** 3 / len(rest)
    s.addEnergy(v.addAttribute("inertia", computed_attribute=E.inertia(
        x, x_hat, mass)))
    add_elastic_tets(mesh, x, rest, tets, mu=1e6, lam=1e6, scale=dt * dt)
    s.addMinimizeTarget(x)
    contact = Contact(s, v, faces=surface_of(tets), dhat=dhat,
                      average_mass=mass, halfspaces=[((0, 0, 0), normal)],
                      friction=mu, eps_v=1e-3, friction_pairs=None
                      if ground_mu is None else {(v, 0): ground_mu})
    stepper = ImplicitEuler(s, x, x_hat, dt=dt, contact=contact, **stepping)
    lowest = np.inf
    # The plane as a triangle for ipctk: (0, t0, t1) with t0 x t1 = normal.
    t0, t1 = tangent_basis(normal).T
    for _ in range(steps):
        report = stepper.step()
        if on_report is not None:
            on_report(report)
        assert all(after <= before for before, after in report.step_energies)
        assert np.isfinite(x.value).all()
        lowest = min(lowest, min(
            ipctk.point_plane_signed_distance(p, np.zeros(3), t0, t1)
            for p in x.value[:, :, 0]))
    slid = float((x.value[:, :, 0] - rest).mean(axis=0) @ down)
    return slid, lowest


def test_block_sticks_below_the_friction_angle_and_slides_above():
    """mu = 0.5 (friction angle 26.6 degrees): on a 15-degree slope the
    block creeps at most eps_v per second; on a 40-degree one it slides
    about as far as g (sin - mu cos) t^2 / 2; it never goes through. At a
    velocity tolerance of 1e-3 m/s: at the default 1e-2 Newton stops while
    the block still gathers speed, and it slides 0.55-0.62x as far,
    depending on how its directions were solved."""
    steps, mu = 20, 0.5
    t = steps * 0.01
    stuck, low_stuck = block_on_slope(15.0, mu, steps,
                                      velocity_tolerance=1e-3)
    slid, low_slid = block_on_slope(40.0, mu, steps, velocity_tolerance=1e-3)
    assert abs(stuck) < 2e-3 * t
    theta = np.radians(40.0)
    free = 0.5 * 9.81 * (np.sin(theta) - mu * np.cos(theta)) * t * t
    assert 0.6 * free < slid < 1.2 * free
    assert min(low_stuck, low_slid) > 0.0


def test_a_pair_of_bodies_takes_its_own_coefficient():
    """The block-slope pair's coefficient overrides the contact's: 0.1
    against a default of 0.5 lets the block slide on a 15-degree slope
    as far as g (sin - 0.1 cos) t^2 / 2 allows; 0.5 against a default of 0
    holds it."""
    steps = 20
    t = steps * 0.01
    slid, low_slid = block_on_slope(15.0, 0.5, steps, ground_mu=0.1,
                                    velocity_tolerance=1e-3)
    stuck, low_stuck = block_on_slope(15.0, 0.0, steps, ground_mu=0.5,
                                      velocity_tolerance=1e-3)
    theta = np.radians(15.0)
    free = 0.5 * 9.81 * (np.sin(theta) - 0.1 * np.cos(theta)) * t * t
    assert 0.6 * free < slid < 1.2 * free
    assert abs(stuck) < 2e-3 * t
    assert min(low_stuck, low_slid) > 0.0


def test_friction_pairs_scale_each_pair_and_refuse_strangers():
    """Between two soft boxes, a pair coefficient of 0.6 against the
    default 0.3 doubles every friction force (forces are linear in mu);
    0 leaves no friction pair; a side that is no member is refused."""
    verts, tets = box_tet_mesh(2, 0.5)
    faces = surface_of(tets)
    upper = verts + [0.1, 0.05, 0.52]
    forces = []
    for name, pairs in (("mu_default", None), ("mu_pair", 0.6),
                        ("mu_none", 0.0)):
        s, prims, (xa, xb), union = two_soft_boxes(name, verts, upper)
        contact = Contact(s, union, faces=np.concatenate(
            [faces, faces + len(verts)]), dhat=0.05, kappa=3.0,
            friction=0.3, eps_v=0.1, friction_pairs=None if pairs is None
            else {(prims[0], prims[1]): pairs})
        s.addMinimizeTarget([xa, xb])
        counts = contact.update(lag=True, dt=0.01)
        xb.updateValue(upper + [2e-3, -1e-3, 0.0])
        forces.append((contact.forces("friction"),
                       sum(counts[f"friction{k}"] for k in (1, 2, 3, 4))))
    (base, n_base), (doubled, n_doubled), (none, n_none) = forces
    assert n_base == n_doubled > 0 and n_none == 0
    assert np.abs(base).max() > 0
    np.testing.assert_allclose(doubled, 2 * base, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(none, 0.0)
    s, prims, _, union = two_soft_boxes("mu_stranger", verts, upper)
    with pytest.raises(SceneError, match="not a member"):
        Contact(s, union, faces=faces, friction=0.3, kappa=1.0,
                friction_pairs={(prims[0], union): 0.5})
    with pytest.raises(SceneError, match="half-space 0; there are 0"):
        Contact(s, union, faces=faces, friction=0.3, kappa=1.0,
                friction_pairs={(prims[0], 0): 0.5})


def test_lagged_friction_iterations_follow_the_sliding_law():
    """A stiff block sliding down a 30-degree slope with mu = 0.2: with
    IPC's lagged friction iterations (normal forces and bases re-lagged at
    each solution until a solve after a lag converges at once) and a
    velocity tolerance of 1e-3 m/s, the distance slid in N steps is
    implicit Euler's under the constant acceleration a = g (sin - mu cos),
    a dt^2 N (N + 1) / 2, to 0.5% (one lag per step: 2.6% too far, and
    12% too short at 1e-2 m/s); every step is lagged more than once."""
    steps, mu, dt = 20, 0.2, 0.01
    theta = np.radians(30.0)
    law = 0.5 * 9.81 * (np.sin(theta) - mu * np.cos(theta)) * dt * dt * \
        steps * (steps + 1)
    reports = []
    slid, lowest = block_on_slope(30.0, mu, steps, friction_iterations=4,
                                  velocity_tolerance=1e-3,
                                  on_report=reports.append)
    assert abs(slid / law - 1) < 5e-3
    assert lowest > 0.0
    assert len(reports) == steps
    assert all(2 <= r.friction_lags <= 4 for r in reports)


def test_contact_update_measures_friction_from_the_step_start():
    """A lag later in a step (``step_start`` given) takes the normal forces
    and bases where the vertex is now, and measures its tangential motion
    from where the step started: the friction energy equals ipctk's
    vertex-triangle FrictionPotential on the displacement from the start,
    with the tangential set built at the current position."""
    dhat, kappa, mu, eps_v, dt = 1e-2, 5.0, 0.4, 0.05, 0.01
    start = np.array([[0.1, -0.05, 4e-3]])
    now = start + [[2e-3, 1e-3, 2e-3]]
    s, v, x = single_vertices("relag", now)
    contact = Contact(s, v, dhat=dhat, kappa=kappa, projection="none",
                      halfspaces=[((0, 0, 0), (0, 0, 1))], friction=mu,
                      eps_v=eps_v)
    with pytest.raises(ValueError, match="step_start has shape"):
        contact.update(lag=True, dt=dt, step_start=start[:, :2])
    assert contact.update(lag=True, dt=dt,
                          step_start=start)["friction1"] == 1
    big = np.array([[-10.0, -10.0, 0.0], [10.0, -10.0, 0.0], [0.0, 10.0, 0.0]])
    V_now, V_start = np.vstack([now, big]), np.vstack([start, big])
    mesh = ipctk.CollisionMesh(V_now, ipctk.edges(np.array([[1, 2, 3]])),
                               np.array([[1, 2, 3]], dtype=np.int32))
    collisions = ipctk.NormalCollisions()
    collisions.build(mesh, V_now, dhat)
    tangential = ipctk.TangentialCollisions()
    tangential.build(mesh, V_now, collisions,
                     ipctk.BarrierPotential(dhat, kappa), mu)
    friction = ipctk.FrictionPotential(eps_v * dt)
    barrier_only = kappa * ipctk.barrier(float(now[0, 2]) ** 2, dhat * dhat)
    want = friction(tangential, mesh, V_now - V_start)
    assert want > 1e-3 * barrier_only  # the motion since the start counts
    assert abs(s.evaluateEnergy() - barrier_only - want) <= \
        1e-10 * want + 1e-14 * barrier_only


def test_newton_stops_on_the_whole_direction_not_the_step_taken():
    """A vertex 5e-5 m above a plane, pulled 0.1 m below it (dhat 1e-5 m,
    the barrier's stiffness balancing the pull at dhat / 2): CCD cuts the
    first step to 0.04% of its direction, a move of 4e-5 m, under the
    tolerance of 1e-4 m. That is no convergence (IPC measures the whole
    direction): Newton goes on until the barrier holds the vertex, within
    dhat, with a force of the pull's order (ipctk's barrier derivative)."""
    dhat, pull = 1e-5, 0.1

    def barrier_force(d: float) -> float:
        return -2 * d * ipctk.barrier_first_derivative(d * d, dhat * dhat)

    kappa = pull / barrier_force(0.5 * dhat)
    s, v, x = single_vertices("cut", np.array([[0.0, 0.0, 5e-5]]))
    x_hat = v.addConstant("x_hat", rows=3)
    x_hat.updateValue([[0.0, 0.0, -pull]])
    s.addEnergy(v.addAttribute("inertia", computed_attribute=E.inertia(
        x, x_hat, 1.0)))
    contact = Contact(s, v, dhat=dhat, kappa=kappa,
                      halfspaces=[((0, 0, 0), (0, 0, 1))])
    report = sim.newton(s, x, tolerance=1e-4, contact=contact)
    assert report.converged and report.iterations > 1
    assert report.step_bounds[0] < 1e-3
    height = float(x.value[0, 2, 0])
    assert 0.0 < height < 0.9 * dhat
    assert 0.3 < kappa * barrier_force(height) / (pull + height) < 3.0


def test_step_bound_follows_a_curved_motion():
    """A vertex on a circle, parameterised by its angle, turns past a static
    triangle that its chord does not reach: ipctk's CCD on the straight
    motion finds nothing, the step bound follows the arc and stops before
    the triangle (where the arc crosses it at 0.182 of the step)."""
    s = yasps.scene("arc")
    mesh = s.addMesh("m")
    p = mesh.addPrimitive("p", numInstances=1)
    angle = p.addAttribute("angle", rows=1)
    angle.updateValue([[-0.5]])
    p.addAttribute("position", computed_attribute=yasps.vstack(
        [angle.cos(), angle.sin(), 0.0 * angle]))
    wall = mesh.addPrimitive("wall", numInstances=3)
    wall.addConstant("position", rows=3).updateValue(
        [[0.95, -0.6, -0.1], [0.95, 0.6, -0.1], [0.95, 0.0, 0.2]])
    union = mesh.addPrimitiveUnion("all", [p, wall])
    union.addAttribute("position")
    contact = Contact(s, union, faces=[[1, 2, 3]], edges=[[1, 2], [2, 3], [3, 1]],
                      dhat=1e-3, kappa=1.0)
    s.addMinimizeTarget(angle)
    step = np.array([[[1.0]]])
    V0 = contact.world()
    V1 = V0.copy()
    V1[0] = [np.cos(0.5), np.sin(0.5), 0.0]
    assert ipctk.compute_collision_free_stepsize(contact.mesh, V0, V1) == 1.0
    crossing = (0.5 - np.arccos(0.95)) / 1.0
    bound = contact.step_bound([step])
    assert 0.5 * crossing < bound < crossing
    # A step that stops short of the wall keeps its whole length.
    assert contact.step_bound([0.1 * step]) == 1.0
