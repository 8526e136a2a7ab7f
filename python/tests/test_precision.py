"""Derivative kernels computed in f32 (``yasps.config.precision``, a
scene's own ``precision``): the IR carries the type, the derivatives agree
with f64 to the bound f32's round-off allows, values stay f64, the Newton
direction and a contact simulation stay close to f64's, and misuse is a
clear error.

The runtime keeps its buffers in f64: an f32 kernel rounds what it loads to
f32, computes in f32 and stores f64, so the bounds below are those of f32
arithmetic on f32-rounded inputs."""

import os
import subprocess
import sys

import ipctk
import numpy as np
import pytest

import yasps
from conftest import REPO
from yasps import energies as E
from yasps.ir import emit_scene
from yasps.sim import NewtonSettings

sys.path.insert(0, str(REPO / "examples"))

import soft_boxes  # noqa: E402

EPS32 = float(np.finfo(np.float32).eps)
EPS64 = float(np.finfo(np.float64).eps)


@pytest.fixture
def f64_default():
    """Restores the process-wide precision and Hessian storage after a test
    that sets them."""
    yield
    yasps.config.precision = "f64"
    yasps.config.hessian_storage = "auto"


def relative(got, want) -> float:
    """Largest error relative to the largest reference entry."""
    return float(np.abs(np.asarray(got) - want).max() / np.abs(want).max())


def tet_scene(precision, seed=0, count=64, offset=0.0):
    """``count`` unit tets, each with vertices of its own (overlapping near
    ``offset``: no contact here), mildly deformed, with stable Neo-Hookean
    through F and inertia, positions the target."""
    rng = np.random.default_rng(seed)
    rest = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    verts = np.concatenate([rest - 0.25 + offset] * count)
    x0 = verts + 0.05 * rng.standard_normal(verts.shape)
    tets = np.arange(4 * count).reshape(count, 4)
    Dm = (rest[1:] - rest[0]).T
    s = yasps.scene("tets", precision=precision)
    m = s.addMesh("m")
    v = m.addPrimitive("v", numInstances=len(verts))
    x = v.addAttribute("x", rows=3)
    x.updateValue(x0)
    hat = v.addConstant("x_hat", rows=3)
    hat.updateValue(verts)
    t = m.addPrimitive("t", numInstances=count)
    t.addConstant("inv", rows=3, cols=3).updateValue(
        np.repeat(np.linalg.inv(Dm)[None], count, axis=0))
    corners = t.addAttribute("c", through=t.addConnectivity("t2v", v, tets, 4),
                             source=x)
    F = E.deformation_gradient(corners, t["inv"])
    s.addEnergy(t.addAttribute("snh", computed_attribute=E.stable_neo_hookean(
        F, 1.0, 10.0, 1.0)))
    s.addEnergy(v.addAttribute("inertia",
                               computed_attribute=E.inertia(x, hat, 2.0)))
    s.addMinimizeTarget(x)
    return s


def test_precision_sets_the_ir_element_type(f64_default):
    s = tet_scene("f32", count=1)
    text = emit_scene(s)
    assert "xf32>" in text and "xf64" not in text
    # A scene without its own precision follows the config.
    s = tet_scene(None, count=1)
    assert "xf64>" in emit_scene(s)
    yasps.config.precision = "f32"
    assert "xf64" not in emit_scene(s)


def test_bad_precisions_are_errors(f64_default):
    with pytest.raises(ValueError, match="precision must be one of"):
        yasps.scene("s", precision="f16")
    with pytest.raises(yasps.ArgumentError, match="precision must be one of"):
        yasps.config.precision = "double"


def test_an_f32_constant_out_of_range_is_an_error():
    s = yasps.scene("big", precision="f32")
    p = s.addMesh("m").addPrimitive("p", numInstances=1)
    x = p.addAttribute("x", rows=1)
    s.addEnergy(p.addAttribute("e", computed_attribute=1e300 * x * x))
    with pytest.raises(ValueError, match="beyond the f32 range"):
        emit_scene(s)


@pytest.mark.parametrize("energy", ["snh", "inertia"])
def test_f32_derivatives_agree_with_f64(energy):
    """Value, gradient and Hessian of each instance within 64 eps32 of the
    largest f64 entry: sums of products of well-scaled entries (moderate
    deformations) lose a few eps of the largest term in either precision.
    They also differ by more than f64's round-off: the kernel really
    computes in f32."""
    def derivatives(precision):
        s = tet_scene(precision)
        return s.energyDerivatives(s.m.t["snh"] if energy == "snh"
                                   else s.m.v["inertia"])

    d64, d32 = derivatives("f64"), derivatives("f32")
    for got, want in ((d32.value, d64.value), (d32.gradient, d64.gradient),
                      (d32.hessian, d64.hessian)):
        assert relative(got, want) <= 64 * EPS32
    assert relative(d32.gradient, d64.gradient) > 16 * EPS64


def test_f32_loses_digits_far_from_the_origin():
    """f32 rounds each coordinate to eps32 |x|, so edge vectors of length h
    carry an error eps32 |x| / h: 1000 units from the origin a unit tet's
    F, and its energy's derivatives, have about three fewer correct digits.
    The bound is 64 eps32 |x| / h; the error is past the near-origin bound
    (docs/accuracy.md: keep scenes near the origin, or use f64)."""
    def derivatives(precision):
        s = tet_scene(precision, offset=1e3)
        return s.energyDerivatives(s.m.t["snh"])

    d64, d32 = derivatives("f64"), derivatives("f32")
    error = relative(d32.gradient, d64.gradient)
    assert 64 * EPS32 < error <= 64 * EPS32 * 1e3


def test_an_f32_scene_far_from_the_origin_warns():
    """minimizeEnergy on an f32 scene 1000 units out (its extent: a few
    units) warns once, naming the target and the loss; f64, or the same
    scene near the origin, does not."""
    import warnings
    far = tet_scene("f32", offset=1e3)
    with pytest.warns(yasps.PrecisionWarning, match=r"attribute 'x' .* of its extent"):
        far.minimizeEnergy()
    with warnings.catch_warnings():
        warnings.simplefilter("error", yasps.PrecisionWarning)
        far.minimizeEnergy()                          # once per scene
        tet_scene("f64", offset=1e3).minimizeEnergy()
        tet_scene("f32").minimizeEnergy()


def test_values_stay_f64_in_an_f32_scene():
    """evaluateEnergy (the line search's comparison) and compute() are f64
    whatever the scene's precision: to 1e-14 of the f64 scene's."""
    want = tet_scene("f64").evaluateEnergy()
    got = tet_scene("f32").evaluateEnergy()
    assert abs(got - want) <= 1e-14 * abs(want)


def test_f32_newton_direction_agrees_with_f64():
    """The Newton direction from f32 local derivatives (PSD-projected in
    f32) and the f64 solve: within 1e-5 relative of f64's, about 100 eps32
    for a system of condition ~10, solved to 1e-10 in both."""
    p64 = tet_scene("f64").minimizeEnergy(tolerance=1e-10)[0]
    p32 = tet_scene("f32").minimizeEnergy(tolerance=1e-10)[0]
    assert relative(p32, p64) <= 1e-5
    assert relative(p32, p64) > 1e3 * EPS64


def test_contact_in_f32_stays_apart_and_near_f64():
    """Eight frames of the boxes in contact in f32: every frame free of
    intersections by ipctk, every accepted step lowering the energy, and
    the trajectory within 1e-6 m of f64's (boxes 20 cm wide: 5e-6 of their
    size; measured 3e-8). The line search's energies and the positions
    given to ipctk are f64 in both runs: with f32 energies the Newton loops
    took other paths and ended 3e-4 m apart."""
    runs = {}
    for precision in ("f64", "f32"):
        boxes = soft_boxes.build(lift=0.205, precision=precision,
                                 name="soft_boxes")
        # Newton and CG converged far past f32's effect on the step, so
        # that the two precisions' trajectories differ by f32, not by
        # where each Newton loop stopped.
        stepper = boxes.stepper(velocity_tolerance=1e-5,
                                settings=NewtonSettings(cg_tolerance=1e-9))
        xs, faces = boxes.xs, boxes.faces
        for _ in range(8):
            # f32 kernels cannot bring every direction below 1e-5 m/s:
            # some steps stop at the cap, as this test means them to.
            report = stepper.step(warn=False)
            V = np.concatenate([x.value[:, :, 0] for x in xs])
            assert np.isfinite(V).all()
            assert all(b <= a for a, b in report.step_energies)
            mesh = ipctk.CollisionMesh(V, ipctk.edges(faces), faces)
            assert not ipctk.has_intersections(mesh, V)
            assert V[:, 2].min() > 0.0
        runs[precision] = V
    gap = np.abs(runs["f32"] - runs["f64"]).max()
    assert 0 < gap <= 1e-6


def test_f32_kernels_store_f32_local_derivatives():
    """An f32 scene's derivative kernels store what they compute, f32 (half
    the bytes), and assembly sums them in f64."""
    s = tet_scene("f32", count=4)
    d = s.energyDerivatives(s.m.t["snh"])
    assert d.gradient.dtype == np.float32 and d.hessian.dtype == np.float32
    assert d.value.dtype == np.float64   # values are f64: compute()


def test_a_second_process_finds_f32_kernels_as_f32(tmp_path):
    """The disk cache's record of an f32 scene's kernels keeps their f32
    output: a later process that loads them by the record alone (nothing
    parsed) reads the same f32 derivatives. Before the record held the
    output type, that process read f32 kernels' output as f64 (garbage)."""
    script = f"""
import sys, numpy as np
sys.path[:0] = [{str(REPO / 'python')!r}, {str(REPO / 'python' / 'tests')!r}]
from test_precision import tet_scene
s = tet_scene("f32", count=4)
d = s.energyDerivatives(s.m.t["snh"])
sys.stdout.buffer.write(d.hessian.dtype.str.encode() + b" " + d.hessian.tobytes())
"""
    env = dict(os.environ, YASPS_CACHE_DIR=str(tmp_path / "cache"))

    def run() -> bytes:
        return subprocess.run([sys.executable, "-c", script], env=env,
                              check=True, capture_output=True).stdout

    first = run()
    assert first.startswith(b"<f4 ")
    assert list((tmp_path / "cache").glob("*.source.json"))
    assert run() == first


def test_f32_hessian_storage_solves_near_the_f64_system(f64_default):
    """hessian_storage="f32": PCG's products read the blocks rounded to f32
    (f64 vectors). The direction is within 1e-5 relative of the f64 one
    (f32's round-off of H times the condition, ~10), and not equal to it:
    the products do read the rounded blocks."""
    p64 = tet_scene("f64").minimizeEnergy(tolerance=1e-10)[0]
    yasps.config.hessian_storage = "f32"
    p32 = tet_scene("f64").minimizeEnergy(tolerance=1e-10)[0]
    assert 0 < relative(p32, p64) <= 1e-5
    with pytest.raises(ValueError, match="hessian_storage must be one of"):
        yasps.config.hessian_storage = "f16"


def test_auto_hessian_storage_rounds_the_blocks_of_large_systems_only(
        f64_default, monkeypatch):
    """hessian_storage="auto" (the default) has the products read f32
    blocks from F32_PRODUCT_MIN_DOFS DoFs (here lowered to the tet
    scene's 192), f64 below: the direction of the same system is then that
    of "f32" or of "f64", bit for bit."""
    yasps.config.hessian_storage = "f64"
    p64 = tet_scene("f64", count=16).minimizeEnergy(tolerance=1e-10)[0]
    yasps.config.hessian_storage = "f32"
    p32 = tet_scene("f64", count=16).minimizeEnergy(tolerance=1e-10)[0]
    assert not np.array_equal(p32, p64)
    yasps.config.hessian_storage = "auto"
    assert yasps.config.resolve_hessian_storage(192) == "f64"
    np.testing.assert_array_equal(
        tet_scene("f64", count=16).minimizeEnergy(tolerance=1e-10)[0], p64)
    monkeypatch.setattr(yasps.config, "F32_PRODUCT_MIN_DOFS", 192)
    assert yasps.config.resolve_hessian_storage(192) == "f32"
    assert yasps.config.resolve_hessian_storage(191) == "f64"
    assert yasps.config.resolve_hessian_storage() == "f64"
    np.testing.assert_array_equal(
        tet_scene("f64", count=16).minimizeEnergy(tolerance=1e-10)[0], p32)


def test_too_many_dofs_for_f32_indices_is_an_error(monkeypatch):
    """f32 kernels compute placement indices (DoF + 1) exactly only below
    2^24 DoFs: a larger f32 scene is refused with a clear error (the limit
    is lowered here to a small scene's 256 DoFs)."""
    import yasps.solve.assembly as assembly
    monkeypatch.setattr(assembly, "_F32_EXACT_INTEGERS", 100)
    with pytest.raises(yasps.SceneError, match="compute this scene in f64"):
        tet_scene("f32", count=16).minimizeEnergy()
    tet_scene("f64", count=16).minimizeEnergy()
