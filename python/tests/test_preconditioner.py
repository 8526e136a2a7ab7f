"""PCG's multilevel preconditioner (``yasps.config.preconditioner``): the
Newton direction it gives agrees with NumPy's dense solve of the assembled
system and with block-Jacobi's, in fewer iterations on a mesh, with and
without fixed DoFs and contact (a dynamic part whose structure changes
between solves)."""

import sys
from pathlib import Path

import numpy as np
import pytest

import yasps
from yasps import energies as E
from yasps.runtime import cpu_backend
from yasps.sim import NewtonSettings, box_tet_mesh
from yasps.solve import assemble

from conftest import ipctk_collisions
from test_minimize import system_arrays


@pytest.fixture
def restore_preconditioner():
    kept = yasps.config.preconditioner
    yield
    yasps.config.preconditioner = kept


def stiff_box(n: int, seed: int = 0):
    """A box of n^3 cells of stable Neo-Hookean tets, stiff against its
    inertia (as a time step would make it), mildly deformed."""
    verts, tets = box_tet_mesh(n)
    rng = np.random.default_rng(seed)
    s = yasps.scene("stiff_box")
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=len(verts))
    t = m.addPrimitive("t", numInstances=len(tets))
    x = v.addAttribute("x", rows=3)
    x.updateValue(verts + rng.normal(scale=0.01 / n, size=verts.shape))
    xh = v.addConstant("x_hat", rows=3)
    xh.updateValue(verts)
    dm = np.stack([verts[tets][:, k] - verts[tets][:, 0] for k in (1, 2, 3)], axis=2)
    inv = t.addConstant("inv", rows=3, cols=3)
    inv.updateValue(np.linalg.inv(dm))
    vol = t.addConstant("vol", rows=1)
    vol.updateValue(np.abs(np.linalg.det(dm))[:, None] / 6)
    c = t.addAttribute("c", through=t.addConnectivity("t2v", v, tets, 4), source=x)
    s.addEnergy(v.addAttribute("inertia", computed_attribute=E.inertia(
        x, xh, 1.0 / len(verts))))
    s.addEnergy(t.addAttribute("snh", computed_attribute=E.stable_neo_hookean(
        E.deformation_gradient(c, inv), 10.0, 40.0, vol)))
    s.addMinimizeTarget([x])
    return s, verts


def direction(scene, preconditioner: str, **kwargs):
    yasps.config.preconditioner = preconditioner
    (dx,) = scene.minimizeEnergy(**kwargs)
    return dx.reshape(-1), dict(scene.lastSolve)


def test_multilevel_solves_the_assembled_system(restore_preconditioner):
    s, _ = stiff_box(8)
    g, H = system_arrays(assemble(s, cpu_backend()).system)
    want = np.linalg.solve(H, g)
    jacobi, jacobi_info = direction(s, "block-jacobi", tolerance=1e-10)
    multilevel, info = direction(s, "multilevel", tolerance=1e-10)
    assert info["converged"] and info["preconditionerLevels"] >= 2
    assert jacobi_info["preconditionerLevels"] == 1
    scale = np.abs(want).max()
    np.testing.assert_allclose(multilevel, want, atol=1e-8 * scale)
    np.testing.assert_allclose(jacobi, want, atol=1e-8 * scale)
    # Fewer than two thirds of block-Jacobi's iterations: what it must save
    # to pay, one of its iterations costing about one and a half of
    # block-Jacobi's (184 against 338 here).
    assert 3 * info["iterations"] <= 2 * jacobi_info["iterations"], (
        info["iterations"], jacobi_info["iterations"])


def test_multilevel_leaves_fixed_dofs(restore_preconditioner):
    s, verts = stiff_box(6)
    bottom = verts[:, 2] < 1e-9
    fixed = [np.repeat(bottom[:, None], 3, axis=1)[:, :, None]]
    jacobi, _ = direction(s, "block-jacobi", tolerance=1e-10, fixed=fixed)
    multilevel, info = direction(s, "multilevel", tolerance=1e-10, fixed=fixed)
    assert info["converged"]
    assert np.all(multilevel.reshape(-1, 3)[bottom] == 0.0)
    np.testing.assert_allclose(multilevel, jacobi, atol=1e-8 * np.abs(jacobi).max())


def test_multilevel_follows_contact_between_solves(restore_preconditioner):
    """A soft box dropped on another: the contact pairs (the dynamic part)
    change from frame to frame. The frames agree with block-Jacobi's, the
    boxes touch, and ipctk finds no intersection."""
    import ipctk
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))
    import soft_boxes

    def simulate(preconditioner: str):
        yasps.config.preconditioner = preconditioner
        boxes = soft_boxes.build(name="boxes_" + preconditioner.replace("-", "_"))
        # Every direction to 1e-10 (no forcing terms): then the frames do
        # not depend on the preconditioner.
        stepper = boxes.stepper(settings=NewtonSettings(cg_tolerance=1e-10,
                                                        cg_forcing=False))
        frames, pairs = [], 0
        for _ in range(10):
            stepper.step()
            V = boxes.positions()
            mesh = ipctk.CollisionMesh(V, ipctk.edges(boxes.faces), boxes.faces)
            assert not ipctk.has_intersections(mesh, V)
            pairs += len(ipctk_collisions(boxes.contact).fv_collisions)
            frames.append(V)
        return np.array(frames), pairs

    jacobi, _ = simulate("block-jacobi")
    multilevel, pairs = simulate("multilevel")
    assert pairs > 0
    np.testing.assert_allclose(multilevel, jacobi, atol=1e-7)


def test_an_unknown_preconditioner_is_refused(restore_preconditioner):
    with pytest.raises(ValueError, match="preconditioner must be one of"):
        yasps.config.preconditioner = "ilu"
    assert yasps.config.preconditioner != "ilu"


GPU_AGAINST_CPU = """
    import sys
    import numpy as np, yasps
    sys.path.insert(0, %r)
    from test_preconditioner import stiff_box
    from test_minimize import mixed_scene
    yasps.config.gpu_derivatives = False
    yasps.config.preconditioner = "multilevel"

    def solve(scene, backend, **kw):
        yasps.config.backend = backend
        out = scene.minimizeEnergy(tolerance=1e-10, **kw)
        info = scene.lastSolve
        assert info["backend"] == backend and info["converged"]
        return np.concatenate([a.reshape(-1) for a in out]), info

    def compare(scene, **kw):
        cpu, cpu_info = solve(scene, "cpu", **kw)
        gpu, gpu_info = solve(scene, "gpu", **kw)
        err = np.abs(gpu - cpu).max() / np.abs(cpu).max()
        print(err < 1e-8, abs(gpu_info["iterations"] - cpu_info["iterations"]) <= 1,
              gpu_info["preconditionerLevels"])

    box, verts = stiff_box(6)
    compare(box)
    bottom = verts[:, 2] < 1e-9
    compare(box, fixed=[np.repeat(bottom[:, None], 3, axis=1)[:, :, None]])
    s, pp, p2v, *_ = mixed_scene([[0, 3], [1, 4]])
    compare(s)
    for pairs in ([[2, 4]], [[0, 1], [2, 3], [1, 4]]):
        pp.updateNumInstances(len(pairs))
        p2v.updateConnectivity(np.array(pairs, dtype=np.int64))
        compare(s)
"""


def test_multilevel_on_the_gpu_backend_matches_the_cpu():
    """The GPU's multilevel PCG (its kernels run by the stand-in driver on
    the host) against the CPU's: the same direction and iteration count, on
    a mesh with three levels, with fixed DoFs, and on a scene whose dynamic
    pairs change between solves."""
    from test_gpu_runtime import FAKE_DRIVER, HAS_PTXAS, run_python
    if not FAKE_DRIVER.exists() or not HAS_PTXAS:
        pytest.skip("needs the stand-in driver and the CUDA toolkit")
    out = run_python(GPU_AGAINST_CPU % str(Path(__file__).resolve().parent),
                     YASPS_CUDA_LIBRARY=str(FAKE_DRIVER))
    lines = [line.split() for line in out.splitlines()]
    assert len(lines) == 5, out
    assert all(line[:2] == ["True", "True"] for line in lines), out
    assert int(lines[0][2]) >= 2, out


@pytest.mark.parametrize("preconditioner", ["block-jacobi", "multilevel"])
def test_a_warm_newton_loop_allocates_no_large_buffers(restore_preconditioner,
                                                       preconditioner):
    """Once warm, minimizeEnergy reuses its NumPy buffers (the local
    derivatives, the DoF masks): over three calls tracemalloc's peak stays
    far below one fresh copy of the local Hessians (6.9 MB), and the
    process takes no new pages (the native side's vectors and levels)."""
    import resource
    import tracemalloc
    s, _ = stiff_box(10)
    yasps.config.preconditioner = preconditioner
    for _ in range(3):
        s.minimizeEnergy(tolerance=1e-6)
    hessian_bytes = 6 * 10 ** 3 * 144 * 8   # 6000 tets' 12x12
    tracemalloc.start()
    try:
        before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
        start, _ = tracemalloc.get_traced_memory()
        for _ in range(3):
            s.minimizeEnergy(tolerance=1e-6)
        _, peak = tracemalloc.get_traced_memory()
        faults = resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before
    finally:
        tracemalloc.stop()
    assert peak - start < hessian_bytes // 10, peak - start
    assert faults < hessian_bytes // 4096 // 10, faults
