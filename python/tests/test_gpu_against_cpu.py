"""The generated GPU kernels against the CPU backend: compute(), energies'
values, gradients, Hessians and projected Hessians, the systems assembled
through their placement indices, and Newton directions, in f64 and f32.

These tests need a usable GPU backend. On a machine with a GPU they run on
it. Without one, ``test_gpu_runtime.py::test_the_gpu_comparisons_pass_on_
the_stand_in_driver`` runs this file in a subprocess against the stand-in
driver (runtime/test/FakeCuda.cpp), which loads host images of the same
kernels: their NVVM-level IR, the IR that becomes the cubins, compiled for
the host (``yasps-nvvm-to-host``) and run block by block and thread by
thread through cuLaunchKernel's parameters. Only NVPTX code generation and
ptxas are left out.
"""

import importlib

import numpy as np
import pytest

from conftest import REPO, point_over_triangle, running_example
from test_contact import rotation, two_soft_boxes
from test_minimize import cloth_patch, mixed_scene, soft_box

import yasps
import yasps.runtime.gpu as gpu_runtime
from yasps.sim import box_tet_mesh
from yasps import energies as E
from yasps.contact import Contact, surface_of
from yasps.ir.emit import KernelIR
from yasps.runtime import current as current_backend
from yasps.solve import assemble as assemble_on
from yasps.runtime.backend import gpu_toolchain_missing

STATUS = yasps.gpu_status()
pytestmark = pytest.mark.skipif(
    not STATUS.usable or bool(gpu_toolchain_missing()),
    reason=f"no usable GPU backend: {STATUS.reason or gpu_toolchain_missing()}")

#: Largest difference from the CPU, relative to the largest CPU value. The
#: host images gave the CPU's values bit for bit in f64 and, but for one
#: barrier Hessian at 1.3e-8, in f32 (the CPU's kernels are vectorised and
#: may contract or reorder differently); a GPU's libdevice and FMA
#: contraction may differ more, within these bounds.
TOLERANCE = {"f64": 1e-12, "f32": 1e-6}


def on(backend: str, monkeypatch, work):
    monkeypatch.setattr(yasps.config, "backend", backend)
    return work()


def assert_close(cpu, gpu, tolerance: float, what: str) -> None:
    cpu, gpu = np.asarray(cpu, dtype=float), np.asarray(gpu, dtype=float)
    assert cpu.shape == gpu.shape, what
    scale = max(float(np.abs(cpu).max(initial=0.0)), 1e-300)
    error = float(np.abs(gpu - cpu).max(initial=0.0)) / scale
    assert error <= tolerance, f"{what}: GPU differs from CPU by {error:.2e}"


def assert_compute_matches(attribute, monkeypatch, tolerance=1e-12):
    cpu = on("cpu", monkeypatch, lambda: attribute.compute().value)
    result = on("gpu", monkeypatch, attribute.compute)
    assert result.stats["backend"] == "gpu"
    assert_close(cpu, result.value, tolerance, attribute.describe())


def test_compute_matches_the_cpu(monkeypatch):
    s = running_example()
    pos = s.bunnies.vertices["position"]
    assert_compute_matches(pos, monkeypatch)
    assert_compute_matches(s.bunny_affine.tets["positions"], monkeypatch)
    assert_compute_matches((pos.dot(pos) + 1.0).log(), monkeypatch)


def test_projection_matches_the_cpu(monkeypatch):
    rng = np.random.default_rng(3)
    s = yasps.scene("proj")
    p = s.addMesh("m").addPrimitive("p", numInstances=1000)
    h = p.addAttribute("h", rows=12, cols=12)
    M = rng.normal(size=(1000, 12, 12))
    h.updateValue(M + np.transpose(M, (0, 2, 1)))
    for method in ("clamp", "abs"):
        assert_compute_matches(h.project(method), monkeypatch)


def fixed_corotated_box():
    """soft_box with fixed corotated elasticity (singular_value_sum)."""
    s = soft_box()
    t = s.m.t
    F = E.deformation_gradient(t["c"], t["inv"])
    s.addEnergy(t.addAttribute("fcr", computed_attribute=E.fixed_corotated(
        F, 10.0, 100.0, t["vol"])))
    return s


def contact_scene():
    """A point 5 mm over a triangle, within the barrier's reach."""
    stepper, _, contact = point_over_triangle("near", 0.005)
    contact.update()
    return stepper.scene


def boxes_in_contact():
    """Two soft boxes within dhat, one turned: point-edge, point-triangle
    and edge-edge barriers, and lagged friction on their pairs."""
    verts, tets = box_tet_mesh(2, 0.5)
    faces = surface_of(tets)
    turned = (verts - 0.25) @ rotation(0.3, [1, 2, 0.5]).T + 0.25
    start = turned + [0.1, 0.05, 0.5 - turned[:, 2].min() + 0.02]
    s, _, (xa, xb), union = two_soft_boxes("touching", verts, start)
    contact = Contact(s, union, faces=np.concatenate([faces, faces + len(verts)]),
                      dhat=0.05, kappa=3.0, friction=0.3, eps_v=0.1)
    s.addMinimizeTarget([xa, xb])
    contact.update(lag=True, dt=0.01)
    xb.updateValue(start + 1e-3)
    contact.update()
    return s


def vertices_over_a_plane():
    """Vertices within dhat of a tilted plane: the half-space barrier and
    its lagged friction, then the vertices moved sideways."""
    rng = np.random.default_rng(7)
    origin, normal = np.array([0.1, -0.2, 0.3]), np.array([0.3, -0.2, 1.0])
    normal /= np.linalg.norm(normal)
    points = origin + rng.normal(scale=0.2, size=(6, 3))
    points += (np.linspace(2e-3, 9e-3, 6) - (points - origin) @ normal)[:, None] \
        * normal
    s = yasps.scene("plane")
    v = s.addMesh("m").addPrimitive("v", numInstances=len(points))
    x = v.addAttribute("position", rows=3)
    x.updateValue(points)
    s.addMinimizeTarget(x)
    contact = Contact(s, v, dhat=1e-2, kappa=2.0, friction=0.3, eps_v=0.1,
                      halfspaces=[(origin, normal)])
    contact.update(lag=True, dt=0.01)
    x.updateValue(points + rng.normal(scale=1e-3, size=points.shape))
    contact.update()
    return s


SCENES = {"soft box": soft_box, "fixed corotated": fixed_corotated_box,
          "mixed": lambda: mixed_scene([[0, 3], [1, 4]])[0],
          "cloth": cloth_patch, "point over triangle": contact_scene,
          "boxes in contact": boxes_in_contact,
          "vertices over a plane": vertices_over_a_plane}


@pytest.mark.parametrize("precision", ["f64", "f32"])
@pytest.mark.parametrize("name", list(SCENES))
def test_energy_derivatives_match_the_cpu(name, precision, monkeypatch):
    """Every energy's values, gradients, Hessians and projected Hessians:
    stable Neo-Hookean, fixed corotated, inertia, affine orthogonality
    through a UNION, Baraff-Witkin, dihedral bending, the IPC barrier of
    every pair kind and of half-spaces, and lagged friction."""
    monkeypatch.setattr(yasps.config, "precision", precision)
    monkeypatch.setattr(yasps.config, "gpu_derivatives", True)
    s = SCENES[name]()
    checked = []
    for energy in s.energies:
        if energy.owner.numInstances == 0:
            continue
        cpu = on("cpu", monkeypatch, lambda: s.energyDerivatives(energy))
        gpu = on("gpu", monkeypatch, lambda: s.energyDerivatives(energy))
        what = f"{energy.describe()} ({precision})"
        assert_close(cpu.value, gpu.value, TOLERANCE[precision],
                     f"value of {what}")
        assert_close(cpu.gradient, gpu.gradient, TOLERANCE[precision],
                     f"gradient of {what}")
        if cpu.hessian is not None:
            assert_close(cpu.hessian, gpu.hessian, TOLERANCE[precision],
                         f"Hessian of {what}")
        assert_close(cpu.projectedHessian, gpu.projectedHessian,
                     TOLERANCE[precision], f"projected Hessian of {what}")
        checked.append(energy.owner.name)
    assert checked, "no energy has instances"
    if name == "boxes in contact":
        assert {"ev", "fv", "ee", "friction3", "friction4"} <= set(checked), \
            checked


def assembled(system):
    """The gradient and the dense Hessian of an assembled system: read out
    on the CPU, and column by column through H e_j on the GPU."""
    g = np.zeros(system.size)
    system.gradient(g)
    H = np.zeros((system.size, system.size))
    if hasattr(system, "dense"):
        system.dense(H.reshape(-1))
        return g, H
    unit, column = np.zeros(system.size), np.zeros(system.size)
    for j in range(system.size):
        unit[j] = 1.0
        system.multiply(unit, column)
        H[:, j] = column
        unit[j] = 0.0
    return g, H


@pytest.mark.parametrize("precision", ["f64", "f32"])
@pytest.mark.parametrize("name", ["soft box", "mixed", "cloth",
                                  "boxes in contact"])
def test_assembled_systems_match_the_cpu(name, precision, monkeypatch):
    """Gradients and projected Hessians placed by the generated index
    kernels and assembled on the device, against the CPU's assembly."""
    monkeypatch.setattr(yasps.config, "precision", precision)
    monkeypatch.setattr(yasps.config, "gpu_derivatives", True)
    s = SCENES[name]()
    systems = {}
    for backend in ("cpu", "gpu"):
        monkeypatch.setattr(yasps.config, "backend", backend)
        system = assemble_on(s, current_backend()).system
        systems[backend] = assembled(system)
    for k, part in enumerate(("gradient", "Hessian")):
        assert_close(systems["cpu"][k], systems["gpu"][k],
                     TOLERANCE[precision], f"assembled {part} of {name}")


#: The paper's scenes (examples/paper) at small scale, at their first frame:
#: every kind of kernel they use (cages and their hex8 Gauss points,
#: angles of a pendulum, points on a sphere, affine bunnies, cloth, soft
#: bodies, contact).
PAPER_SCENES = {
    "cloths on bunny": ("cloths_on_bunny", lambda m: m.build("small", 1)),
    "caged bunny tet4": ("caged_bunny", lambda m: m.build("small", "tet4", 4)),
    "caged bunny hex8": ("caged_bunny", lambda m: m.build("small", "hex8", 4)),
    "mixed materials": ("mixed_materials", lambda m: m.build("small")),
    "many bunnies": ("many_bunnies", lambda m: m.build("small", 2)),
    "mat twist": ("mat_twist", lambda m: m.build("small")),
    "pendulum": ("pendulum", lambda m: m.build()),
    "repulsive curve": ("repulsive_curve", lambda m: repulsive_curve(m)),
}


def repulsive_curve(module):
    """Stage 3 of repulsive_curve.py: 64 points on the sphere, uniform
    density."""
    curve = module.Curve(64, lambda points: np.ones(len(points)))
    curve.prepare()
    return (curve,)


@pytest.mark.skipif(not (REPO.parent / "shared" / "data" /
                         "bunny-1.8k.msh").exists(),
                    reason="../shared/data/bunny-1.8k.msh missing")
@pytest.mark.parametrize("name", list(PAPER_SCENES))
def test_paper_scene_kernels_match_the_cpu(name, monkeypatch):
    """Every energy with instances of each paper scene: values, gradients,
    Hessians and projected Hessians, f64."""
    monkeypatch.syspath_prepend(str(REPO / "examples" / "paper"))
    module_name, build = PAPER_SCENES[name]
    built = build(importlib.import_module(module_name))
    scene = getattr(built[0], "scene", built[0])
    monkeypatch.setattr(yasps.config, "gpu_derivatives", True)
    checked = 0
    for energy in scene.energies:
        if energy.owner.numInstances == 0 or not scene.minimizeTargets:
            continue
        cpu = on("cpu", monkeypatch, lambda: scene.energyDerivatives(energy))
        gpu = on("gpu", monkeypatch, lambda: scene.energyDerivatives(energy))
        for part in ("value", "gradient", "hessian", "projectedHessian"):
            if getattr(cpu, part) is not None:
                assert_close(getattr(cpu, part), getattr(gpu, part),
                             TOLERANCE["f64"], f"{part} of {energy.describe()}")
        checked += 1
    assert checked >= 2


def newton_directions(monkeypatch, precision: str):
    monkeypatch.setattr(yasps.config, "precision", precision)
    monkeypatch.setattr(yasps.config, "gpu_derivatives", True)
    for separate in (False, True):
        monkeypatch.setattr(yasps.config, "separate_reduced_hessians", separate)
        for scene in (soft_box(), mixed_scene([[0, 3], [1, 4]])[0],
                      cloth_patch()):
            directions = {}
            for backend in ("cpu", "gpu"):
                out = on(backend, monkeypatch,
                         lambda: scene.minimizeEnergy(tolerance=1e-12))
                assert scene.lastSolve["backend"] == backend
                directions[backend] = np.concatenate(
                    [a.reshape(-1) for a in out])
            assert scene.lastSolve["energiesDifferentiatedOnGpu"] > 0
            yield scene, separate, directions


@pytest.mark.parametrize("precision", ["f64", "f32"])
def test_newton_directions_match_the_cpu(precision, monkeypatch):
    """minimizeEnergy with derivatives, placement indices, assembly and PCG
    on the GPU, with and without separated reduced Hessians. The GPU's PCG
    sums in another order, and a solve to 1e-12 amplifies that and the
    kernels' round-off by the system's condition number (measured: 1e-10 in
    f64, 2.9e-6 in f32 on the mixed scene)."""
    tolerance = {"f64": 1e-9, "f32": 1e-4}[precision]
    for scene, separate, d in newton_directions(monkeypatch, precision):
        assert_close(d["cpu"], d["gpu"], tolerance,
                     f"direction of {scene.name} (separate {separate})")


def test_a_broken_generated_kernel_is_caught(monkeypatch):
    """The comparisons above would see a kernel that computes something
    else: here the GPU's stable Neo-Hookean is compiled from IR whose
    lambda / 2 (the constant 50 of lambda = 100) was changed to 55."""
    compile_ir = gpu_runtime.compile_ir

    def broken(ir, *args, **kwargs):
        assert ir.count("dense<50.0>") == 1
        changed = KernelIR(ir.replace("dense<50.0>", "dense<55.0>"),
                           ir.locations)
        return compile_ir(changed, *args, **kwargs)

    monkeypatch.setattr(gpu_runtime, "compile_ir", broken)
    monkeypatch.setattr(yasps.config, "gpu_derivatives", True)
    s = soft_box()
    # IR of its own: kernels compiled earlier in this process are not reused.
    s.m.t.addConstant("unused", rows=1)
    energy = s.m.t["snh"]
    cpu = on("cpu", monkeypatch, lambda: s.energyDerivatives(energy))
    gpu = on("gpu", monkeypatch, lambda: s.energyDerivatives(energy))
    with pytest.raises(AssertionError, match="GPU differs from CPU"):
        assert_close(cpu.gradient, gpu.gradient, TOLERANCE["f64"], "gradient")
