"""Articulated bodies in joint coordinates (yasps.articulated), checked
against Pinocchio, an independent rigid-body dynamics library: forward
kinematics and the Jacobians of the links' points to 1e-12, the
joint-space mass matrix to 1e-10 relative, on the shipped URDFs; the URDF
reader's refusals; and a swinging chain stepped by implicit Euler against
Pinocchio's forward dynamics integrated with RK4."""

import os
import sys
from pathlib import Path

import numpy as np
import pytest

import yasps
from yasps.articulated import (KinematicTree, Joint, Link,
                               add_articulated_body, inertia_points,
                               mass_matrix, point_jacobians, read_urdf)
from yasps.sim import ImplicitEuler

pin = pytest.importorskip("pinocchio")

REPO = Path(__file__).resolve().parents[2]
URDF = REPO / "examples" / "articulated" / "urdf"
ROBOTS = ["pendulum_chain", "arm_gripper"]


def built(name: str, floating: bool = False):
    path = URDF / f"{name}.urdf"
    scene = yasps.scene(f"articulated_{name}")
    body = add_articulated_body(scene, read_urdf(path), floating=floating)
    scene.addMinimizeTarget(body.targets)
    return scene, body, path


def random_coordinates(body, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1.2, 1.2, len(body.joints))
    for k, joint in enumerate(body.joints):
        if joint.kind == "prismatic":
            q[k] = rng.uniform(joint.lower, joint.upper)
    return q


class Reference:
    """Pinocchio's model of the same file, its coordinates set from
    yasps' (a continuous joint is (cos, sin) there) and its velocity
    columns in yasps' order."""

    def __init__(self, path: Path, names, free_flyer: bool = False):
        self.model = pin.buildModelFromUrdf(
            str(path), pin.JointModelFreeFlyer()) if free_flyer else \
            pin.buildModelFromUrdf(str(path))
        self.data = self.model.createData()
        self.joints = [self.model.joints[self.model.getJointId(n)]
                       for n in names]
        self.columns = [j.idx_v for j in self.joints]

    def configuration(self, q, base=None) -> np.ndarray:
        config = pin.neutral(self.model)
        for joint, value in zip(self.joints, q):
            if joint.nq == 2:
                config[joint.idx_q:joint.idx_q + 2] = [np.cos(value),
                                                       np.sin(value)]
            else:
                config[joint.idx_q] = value
        if base is not None:
            config[:7] = pin.SE3ToXYZQUAT(base)
        return config

    def kinematics(self, config) -> None:
        pin.computeJointJacobians(self.model, self.data, config)
        pin.updateFramePlacements(self.model, self.data)

    def placement(self, link: str) -> np.ndarray:
        return self.data.oMf[self.model.getFrameId(link)].homogeneous

    def point_jacobian(self, link: str, point: np.ndarray) -> np.ndarray:
        frame = self.model.getFrameId(link)
        J = pin.getFrameJacobian(self.model, self.data, frame,
                                 pin.LOCAL_WORLD_ALIGNED)[:, self.columns]
        r = point - self.data.oMf[frame].translation
        return J[:3] + np.cross(J[3:].T, r).T

    def mass_matrix(self, config) -> np.ndarray:
        M = pin.crba(self.model, self.data, config)
        M = np.triu(M) + np.triu(M, 1).T
        return M[np.ix_(self.columns, self.columns)]


@pytest.mark.parametrize("robot", ROBOTS)
def test_kinematics_jacobians_and_mass_matrix_equal_pinocchio(robot):
    scene, body, path = built(robot)
    ref = Reference(path, body.joint_names)
    for seed in (1, 2):
        q = random_coordinates(body, seed)
        body.set_joint_positions(q)
        ref.kinematics(ref.configuration(q))
        for link, T in body.link_transforms().items():
            assert np.abs(T - ref.placement(link)).max() < 1e-12, link
        moving = [d for d in body.depths if d.inertia is not None]
        for depth, J in zip(moving, point_jacobians(scene, body)):
            owner = depth.points.connectivities["body"].indices[:, 0]
            x = depth.inertia.world()[:, :, 0]
            for i in range(len(x)):
                link = body.bodies[depth.bodies[owner[i]]].joint.child
                assert np.abs(J[i] - ref.point_jacobian(link, x[i])).max() \
                    < 1e-12, (link, i)
        M, expected = mass_matrix(scene, body), ref.mass_matrix(
            ref.configuration(q))
        assert np.abs(M - expected).max() <= 1e-10 * np.abs(expected).max()


def test_a_floating_base_places_the_tree_and_carries_its_mass():
    scene, body, path = built("arm_gripper", floating=True)
    ref = Reference(path, body.joint_names, free_flyer=True)
    q = random_coordinates(body, 3)
    body.set_joint_positions(q)
    w, t = np.array([0.3, -0.5, 0.2]), np.array([0.1, 0.2, -0.3])
    body.base_w.updateValue(w.reshape(1, 3, 1))
    body.base_t.updateValue(t.reshape(1, 3, 1))
    ref.kinematics(ref.configuration(q, pin.SE3(pin.exp3(w), t)))
    for link, T in body.link_transforms().items():
        assert np.abs(T - ref.placement(link)).max() < 1e-12, link
    # x = R(w) X + t for every point: dx/dt is the identity, so the
    # translations' block of the mass matrix is the total mass.
    total = sum(link.mass for link in body.tree.links.values())
    M = mass_matrix(scene, body)
    assert np.abs(M[3:6, 3:6] - total * np.eye(3)).max() < 1e-12 * total


def test_inertia_points_have_the_links_mass_centre_and_inertia():
    rng = np.random.default_rng(0)
    A = rng.normal(size=(3, 3))
    inertia = A @ A.T + np.trace(A @ A.T) * np.eye(3)  # a physical tensor
    com = np.array([0.1, -0.2, 0.3])
    points, masses = inertia_points(2.0, com, inertia)
    assert masses.sum() == pytest.approx(2.0, rel=1e-15)
    assert np.abs(masses @ points / 2.0 - com).max() < 1e-15
    r = points - com
    second = np.einsum("i,ij,ik->jk", masses, r, r)
    rebuilt = np.trace(second) * np.eye(3) - second
    assert np.abs(rebuilt - inertia).max() < 1e-12 * np.abs(inertia).max()
    with pytest.raises(yasps.SceneError, match="triangle inequality"):
        inertia_points(1.0, com, np.diag([1.0, 1.0, 3.0]))


def test_a_joint_that_moves_no_mass_is_refused():
    tree = KinematicTree({"a": Link("a", 1.0, inertia=np.eye(3)),
                          "b": Link("b")},
                         [Joint("j", "revolute", "a", "b",
                                axis=np.array([0.0, 0.0, 1.0]))])
    with pytest.raises(yasps.SceneError, match="'j' moves no mass"):
        add_articulated_body(yasps.scene("massless"), tree)


UNSUPPORTED = {
    "planar joint": ('<joint name="slider" type="planar"><parent link="a"/>'
                     '<child link="b"/></joint>', "joint 'slider'"),
    "mimic": ('<joint name="m" type="revolute"><parent link="a"/>'
              '<child link="b"/><mimic joint="x"/>'
              '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>',
              "<mimic>"),
    "damping": ('<joint name="d" type="revolute"><parent link="a"/>'
                '<child link="b"/><dynamics damping="0.5"/>'
                '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>',
                "<dynamics>"),
    "unknown element": ('<joint name="u" type="fixed"><parent link="a"/>'
                        '<child link="b"/><spring k="3"/></joint>',
                        "<spring> in <joint> of joint 'u'"),
}


@pytest.mark.parametrize("case", sorted(UNSUPPORTED))
def test_an_unsupported_urdf_element_is_named(tmp_path, case):
    joint, named = UNSUPPORTED[case]
    link = ('<link name="{}"><inertial><mass value="1"/><inertia ixx="1" '
            'ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>')
    path = tmp_path / "robot.urdf"
    path.write_text(f'<robot name="r">{link.format("a")}{link.format("b")}'
                    f'{joint}</robot>')
    with pytest.raises(yasps.ModelFileError, match=named.replace(
            "(", r"\(")) as caught:
        read_urdf(path)
    assert isinstance(caught.value, yasps.YaspsError)


def rk4_swing(ref: Reference, q0, seconds: float, steps: int) -> np.ndarray:
    """Pinocchio's forward dynamics (ABA) from rest, integrated by RK4."""
    n = len(q0)

    def rate(state):
        q, v = state[:n], state[n:]
        config = ref.configuration(q)
        velocity = np.zeros(ref.model.nv)
        velocity[ref.columns] = v
        a = pin.aba(ref.model, ref.data, config, velocity,
                    np.zeros(ref.model.nv))
        return np.concatenate([v, a[ref.columns]])

    state, h = np.concatenate([q0, np.zeros(n)]), seconds / steps
    for _ in range(steps):
        k1 = rate(state)
        k2 = rate(state + h / 2 * k1)
        k3 = rate(state + h / 2 * k2)
        k4 = rate(state + h * k3)
        state = state + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return state[:n]


def implicit_euler_swing(q0, seconds: float, dt: float) -> np.ndarray:
    scene, body, _ = built("pendulum_chain")
    body.set_joint_positions(q0)
    stepper = ImplicitEuler(scene, targets=body.targets, dt=dt,
                            world=body.world, velocity_tolerance=1e-7)
    for _ in range(round(seconds / dt)):
        stepper.step()
    return body.joint_positions()


def test_a_swinging_chain_follows_rigid_body_dynamics():
    """Implicit Euler is first order: its error against the reference
    halves with the time step, and is small at the finer one."""
    q0 = np.array([0.8, -0.4, 0.6])
    _, body, path = built("pendulum_chain")
    ref = Reference(path, body.joint_names)
    ref.model.gravity.linear = np.array([0.0, 0.0, -9.81])
    seconds = 0.2
    exact = rk4_swing(ref, q0, seconds, 400)
    coarse = np.abs(implicit_euler_swing(q0, seconds, 0.01) - exact).max()
    fine = np.abs(implicit_euler_swing(q0, seconds, 0.005) - exact).max()
    assert 1.6 < coarse / fine < 2.4, (coarse, fine)
    assert fine < 0.05, fine


def lever(lower: float, upper: float) -> KinematicTree:
    """A 0.4 m horizontal bar on a hinge about y, limited to [lower,
    upper]: gravity turns it down (positive angles)."""
    bar = Link("bar", 1.0, np.array([0.2, 0.0, 0.0]),
               np.diag([1e-4, 0.0134, 0.0134]))
    return KinematicTree({"post": Link("post"), "bar": bar},
                         [Joint("hinge", "revolute", "post", "bar",
                                axis=np.array([0.0, 1.0, 0.0]),
                                lower=lower, upper=upper)])


def test_a_joint_limit_is_never_crossed_and_holds_the_bar():
    from yasps.articulated import add_joint_limits
    scene = yasps.scene("limited_lever")
    body = add_articulated_body(scene, lever(-0.3, 0.3))
    scene.addMinimizeTarget(body.targets)
    limits = add_joint_limits(scene, body)
    # The energy is IPC's barrier, scaled: value at a distance of dhat / 2.
    dhat, kappa = limits.dhat[0], limits.stiffness[0]
    body.set_joint_positions([0.3 - dhat / 2])
    value = scene.energyDerivatives(limits.energies[0]).value[0]
    d = dhat / 2
    assert value == pytest.approx(-kappa * (d - dhat) ** 2 * np.log(d / dhat),
                                  rel=1e-12)
    body.set_joint_positions([0.0])
    stepper = ImplicitEuler(scene, targets=body.targets, dt=0.01,
                            world=body.world, velocity_tolerance=1e-5)
    angles = []
    for _ in range(60):
        report = stepper.step()
        assert report.converged
        angles.append(body.joint_positions()[0])
    angles = np.array(angles)
    assert (angles < 0.3).all() and (angles > -0.3).all()
    # It swung into the limit and rests within dhat of it.
    assert angles.max() > 0.3 - dhat
    assert abs(angles[-1] - 0.3) < dhat


def test_a_start_outside_the_limits_is_refused():
    from yasps.articulated import add_joint_limits
    scene = yasps.scene("outside_lever")
    body = add_articulated_body(scene, lever(0.1, 0.3))
    scene.addMinimizeTarget(body.targets)
    with pytest.raises(yasps.SceneError, match="'hinge'"):
        add_joint_limits(scene, body)


def test_drives_hold_the_chain_with_pinocchios_gravity_torques():
    """PD drives hold the pendulum chain at its targets under gravity; at
    rest their torques are the joint-space gravity of Pinocchio's RNEA."""
    from yasps.articulated import add_joint_drives
    scene, body, path = built("pendulum_chain")
    target = np.array([0.3, -0.2, 0.4])
    body.set_joint_positions(target)
    drives = add_joint_drives(scene, body, 0.01, stiffness=400.0,
                              damping=20.0)
    drives.set_targets(target)
    stepper = ImplicitEuler(scene, targets=body.targets, dt=0.01,
                            world=body.world, velocity_tolerance=1e-7)
    drives.attach(stepper)
    for _ in range(150):
        stepper.step()
    q = body.joint_positions()
    assert np.abs(q - target).max() < 0.05   # held near the targets
    ref = Reference(path, body.joint_names)
    gravity = pin.computeGeneralizedGravity(
        ref.model, ref.data, ref.configuration(q))[ref.columns]
    torques = drives.torques()
    assert np.abs(torques - gravity).max() <= 1e-2 * np.abs(gravity).max()


def test_a_scheduled_drive_follows_its_targets_in_time():
    from yasps.articulated import add_joint_drives
    scene = yasps.scene("scheduled_lever")
    body = add_articulated_body(scene, lever(-1.0, 1.0))
    scene.addMinimizeTarget(body.targets)
    drives = add_joint_drives(scene, body, 0.01, stiffness=50.0, damping=2.0)
    drives.schedule = lambda t: {"positions": 0.5 * t, "velocities": 0.5}
    stepper = ImplicitEuler(scene, targets=body.targets, dt=0.01,
                            world=body.world, velocity_tolerance=1e-6)
    drives.attach(stepper)
    for _ in range(40):
        stepper.step()
    assert drives.targets[0] == pytest.approx(0.5 * stepper.time, rel=1e-12)
    assert drives.target_velocities[0] == pytest.approx(0.5, rel=1e-12)
    # The bar follows, off its target by the sag under gravity.
    assert abs(body.joint_positions()[0] - 0.5 * stepper.time) < 0.1
    with pytest.raises(yasps.SceneError, match="dt = 0.01"):
        drives.attach(ImplicitEuler(scene, targets=body.targets, dt=0.02,
                                    world=body.world))


def articulated_example(name: str):
    """examples/articulated/<name>.py as a module."""
    import importlib.util
    path = REPO / "examples" / "articulated" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"{name}_example", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module   # for its dataclasses
    spec.loader.exec_module(module)
    return module


def test_the_gripper_lifts_and_holds_the_soft_cube():
    """examples/articulated/gripper.py: drives close the fingers on a soft
    cube (friction 0.5), raise it 5 cm and hold it: every frame converged,
    free of intersections (ipctk, apart from yasps' own queries) and inside
    the joint limits; the cube leaves the ground and slips under 1 mm
    during the hold; the lift drive's force carries the palm, the fingers
    and the cube within 1%."""
    import ipctk
    example = articulated_example("gripper")
    gripping = example.build()
    robot, limits = gripping.robot, gripping.limits
    lift = robot.joint_names.index("lift")
    mesh = ipctk.CollisionMesh(gripping.contact.world(),
                               ipctk.edges(gripping.faces), gripping.faces)
    held = []
    frames = example.CLOSE + example.RAISE + 15
    for frame in range(frames):
        report = gripping.stepper.step(warn=False)
        assert report.converged, frame
        assert not ipctk.has_intersections(mesh, gripping.contact.world()), \
            frame
        q = robot.joint_positions()
        assert ((q > limits.lower) & (q < limits.upper)).all(), (frame, q)
        if frame >= frames - 10:
            cube_height = gripping.box.body.x.value[:, 2, 0].mean()
            held.append(cube_height - q[lift])
    assert gripping.box.body.x.value[:, 2, 0].min() > 0.03   # off the ground
    assert np.ptp(held) < 1e-3                           # slip over the hold
    weight = example.carried_mass(gripping) * 9.81
    assert gripping.drives.torques()[lift] == pytest.approx(weight, rel=1e-2)


def test_urdf_geometry_becomes_surfaces_in_the_links_frames(tmp_path):
    """A collision mesh file (scaled, placed by its origin) and URDF's
    shapes: their vertices where the file puts them, their faces closed."""
    import meshio
    from yasps.articulated import box_surface, cylinder_surface
    corners = box_surface([1.0, 2.0, 3.0])
    meshio.write_points_cells(tmp_path / "part.obj", corners.vertices,
                              [("triangle", corners.faces)])
    (tmp_path / "robot.urdf").write_text(
        '<robot name="r"><link name="a"><collision>'
        '<origin xyz="0.5 0 0" rpy="0 0 1.5707963267948966"/>'
        '<geometry><mesh filename="part.obj" scale="0.1 0.1 0.1"/>'
        '</geometry></collision><collision><geometry>'
        '<cylinder radius="0.2" length="0.4"/></geometry></collision>'
        '</link></robot>')
    link = read_urdf(tmp_path / "robot.urdf").links["a"]
    mesh, cylinder = link.surfaces
    # Half extents (0.05, 0.1, 0.15) turned a quarter about z, then moved.
    assert np.allclose(mesh.vertices.min(0), [0.4, -0.05, -0.15])
    assert np.allclose(mesh.vertices.max(0), [0.6, 0.05, 0.15])
    expected = cylinder_surface(0.2, 0.4)
    assert np.allclose(cylinder.vertices, expected.vertices)
    for surface in (mesh, cylinder):
        edges = np.sort(np.concatenate([surface.faces[:, [0, 1]],
                                        surface.faces[:, [1, 2]],
                                        surface.faces[:, [2, 0]]]), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        assert (counts == 2).all()   # closed: every edge on two triangles


@pytest.mark.skipif(not os.environ.get("YASPS_LONG_TESTS"),
                    reason="compiles for 2.8 min (cold, two cores) beside "
                    "the gripper's contact: set YASPS_LONG_TESTS=1")
def test_the_arm_pushes_the_box_round_the_table():
    """examples/articulated/pusher.py: the shoulder's drive sweeps the
    paddle into a soft box on the table (friction 0.3) and pushes it round:
    every frame converged, free of intersections by ipctk and inside the
    limits; the box moved round by more than 0.25 rad and stayed on the
    table. Not in the test command (YASPS_LONG_TESTS=1 runs it): its cold
    compile took 166 s of it."""
    import ipctk
    example = articulated_example("pusher")
    pushing = example.build()
    mesh = ipctk.CollisionMesh(pushing.contact.world(),
                               ipctk.edges(pushing.faces), pushing.faces)
    for frame in range(100):
        report = pushing.stepper.step(warn=False)
        assert report.converged, frame
        assert not ipctk.has_intersections(mesh, pushing.contact.world()), \
            frame
        q = pushing.robot.joint_positions()
        assert ((q > pushing.limits.lower) & (q < pushing.limits.upper)).all()
    assert example.box_angle(pushing) > example.START + 0.25
    heights = pushing.box.body.x.value[:, 2, 0]
    assert 0.0 < heights.min() < 2e-3   # resting on the table
