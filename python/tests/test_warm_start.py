"""ImplicitEuler's warm start: Newton starts from x + dt v, cut by the step
bounds. Its first direction is the change of velocity, it reaches the same
minimiser, and a guess that would pass through a surface is cut by CCD."""

import ipctk
import numpy as np

import yasps
from yasps import energies as E
from yasps.sim import ImplicitEuler, box_tet_mesh

from conftest import point_over_triangle


def swinging_box(warm_start: bool):
    """A soft box hanging by one top edge, swinging under gravity."""
    verts, tets = box_tet_mesh(1, size=0.2)
    rest = verts[tets]
    dm = np.stack([rest[:, k] - rest[:, 0] for k in (1, 2, 3)], axis=2)
    s = yasps.scene(f"swing_{warm_start}")
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=len(verts))
    t = m.addPrimitive("t", numInstances=len(tets))
    x = v.addAttribute("x", rows=3)
    x.updateValue(verts)
    x_hat = v.addConstant("x_hat", rows=3)
    x_hat.updateValue(verts)
    t.addConstant("inv", rows=3, cols=3).updateValue(np.linalg.inv(dm))
    t.addConstant("vol", rows=1).updateValue(
        np.abs(np.linalg.det(dm))[:, None] / 6)
    c = t.addAttribute("c", through=t.addConnectivity("t2v", v, tets, 4),
                       source=x)
    dt = 1e-2
    s.addEnergy(t.addAttribute("elastic", computed_attribute=dt * dt *
                               E.stable_neo_hookean(
                                   E.deformation_gradient(c, t["inv"]),
                                   2e3, 5e3, t["vol"])))
    s.addEnergy(v.addAttribute("inertia",
                               computed_attribute=E.inertia(x, x_hat, 0.1)))
    s.addMinimizeTarget([x])
    edge = (verts[:, 2] == verts[:, 2].max()) & (verts[:, 0] == 0.0)
    return x, ImplicitEuler(s, x, x_hat, dt, fixed=edge,
                            velocity_tolerance=1e-5, warm_start=warm_start)


def test_warm_start_corrects_only_the_change_of_velocity():
    """Newton's first direction from x + dt v is the change of velocity
    (times dt), from x the whole motion: once the box swings it is a
    quarter or less; the steps reach the same minimiser, in no more
    iterations."""
    runs = {}
    for warm in (False, True):
        x, stepper = swinging_box(warm)
        iterations, first, positions = 0, [], []
        for _ in range(15):
            report = stepper.step()
            assert report.converged
            iterations += report.iterations
            first.append(report.residuals[0])
            positions.append(x.value.copy())
        runs[warm] = iterations, np.asarray(first), np.asarray(positions)
    (cold, cold_first, cold_x), (warm, warm_first, warm_x) = \
        runs[False], runs[True]
    assert warm <= cold
    assert warm_first[0] == cold_first[0]  # at rest, the same start
    assert (warm_first[4:] < 0.25 * cold_first[4:]).all()
    # Both stop within 1e-5 m/s * dt of the same minimiser per step.
    assert np.abs(warm_x - cold_x).max() < 1e-6
    assert np.abs(cold_x[-1] - cold_x[0]).max() > 1e-2  # it did swing


def test_warm_start_is_cut_where_it_would_pass_through_a_surface():
    """A point at 30 m/s towards a fixed triangle 0.1 m below: x + dt v
    lies 0.2 m beyond it. The guess stops short of the triangle and the
    point never crosses it (ipctk)."""
    stepper, x, contact = point_over_triangle("warm_ccd", 0.1)
    V = x.value[:, :, 0].copy()
    stepper.velocities[0][3, 2, 0] = -30.0
    mesh = ipctk.CollisionMesh(V, np.array([[0, 1], [1, 2], [2, 0]]),
                               np.array([[0, 1, 2]]))
    start = x.value.copy()
    for _ in range(3):
        stepper.step()
        now = x.value[:, :, 0]
        assert now[3, 2] > 0.0
        assert ipctk.is_step_collision_free(mesh, start[:, :, 0], now)
        start = x.value.copy()
    # The guess was cut: without the cut the point would have started
    # below the triangle, where the barrier does not reach.
    x.updateValue(V[:, :, None])
    stepper.velocities[0][3, 2, 0] = -30.0
    stepper._start_from_velocities(None)
    assert 0.0 < x.value[3, 2, 0] < 0.1


def test_a_body_at_rest_on_the_ground_does_not_creep_into_it():
    """A stiff affine box resting on the ground at dt = 0.1 s: velocities
    below Newton's tolerance are not carried into the next step's guess.
    Before, each guess pressed the box further into the barrier (cut by
    CCD to a fraction of its distance) and Newton stopped at once: its
    lowest vertex fell from 2e-8 m at frame 5 to 9e-17 m at frame 14, and
    below the ground by rounding at frame 15 (bench/extremes.py)."""
    from yasps.contact import Contact, Relative, surface_of
    from yasps.sim import add_affine_body, lumped_masses

    verts, tets = box_tet_mesh(2, size=0.1)
    verts = verts - [0.05, 0.05, 0.0]
    masses = lumped_masses(verts, tets, 1000.0)
    s = yasps.scene("resting_affine")
    body = add_affine_body(s.addMesh("rigid"), verts, masses,
                           stiffness=1e8 * 1e-3, scale=1e-2,
                           translation=(0.0, 0.0, 0.44))
    contact = Contact(s, body.vertices, faces=surface_of(tets), dhat=2e-4,
                      halfspaces=[((0, 0, 0), (0, 0, 1))], points=False)
    s.addMinimizeTarget([body.A, body.t])
    stepper = ImplicitEuler(s, [body.A, body.t], [body.A_hat, body.t_hat],
                            dt=0.1, gravity=[None, (0, 0, -9.81)],
                            contact=contact,
                            velocity_tolerance=Relative(1e-2))
    lowest = []
    for _ in range(25):
        assert stepper.step().converged
        lowest.append(contact.world()[:, 2].min())
    assert lowest[2] < 2e-4  # landed within dhat
    assert min(lowest[5:]) > 0.5 * lowest[5] > 0.0
