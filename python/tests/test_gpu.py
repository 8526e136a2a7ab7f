"""GPU code generation: every kernel of the running example and of the demo
scene becomes a cubin per chip (a CUDA ELF with the kernel's symbol) and PTX.
These tests need the CUDA toolkit's ptxas, not a GPU."""

import shutil
import struct
import sys

import pytest

from conftest import REPO, running_example

import yasps
import yasps.compiler.gpu
import yasps.runtime.native

sys.path.insert(0, str(REPO / "examples"))
import drop  # noqa: E402

pytestmark = pytest.mark.skipif(
    shutil.which("ptxas", path="/usr/local/cuda/bin:/usr/bin") is None,
    reason="the CUDA toolkit (ptxas) is not installed")

EM_CUDA = 190
STT_FUNC = 2


def elf_function_symbols(data: bytes) -> set:
    """Names of the function symbols of a 64-bit little-endian ELF file,
    read from its section headers and symbol table."""
    assert data[:4] == b"\x7fELF", "not an ELF file"
    assert data[4] == 2 and data[5] == 1, "not 64-bit little-endian"
    machine, = struct.unpack_from("<H", data, 18)
    assert machine == EM_CUDA, f"e_machine {machine} is not EM_CUDA"
    shoff, = struct.unpack_from("<Q", data, 40)
    shentsize, shnum = struct.unpack_from("<HH", data, 58)
    sections = [struct.unpack_from("<IIQQQQIIQQ", data, shoff + i * shentsize)
                for i in range(shnum)]
    names = set()
    for sh_type, offset, size, link, entsize in (
            (s[1], s[4], s[5], s[6], s[9]) for s in sections):
        if sh_type != 2:  # SHT_SYMTAB
            continue
        strtab = sections[link][4]
        for k in range(size // entsize):
            name, info = struct.unpack_from("<IB", data, offset + k * entsize)
            if info & 0xF == STT_FUNC:
                end = data.index(b"\0", strtab + name)
                names.add(data[strtab + name:end].decode())
    return names


def check_binaries(kernels: yasps.compiler.gpu.GpuKernels, chips) -> None:
    names = {k.name for k in kernels.kernels}
    for chip in chips:
        assert names <= elf_function_symbols(kernels.binaries[(chip, "cubin")])
    ptx = kernels.binaries[(max(chips), "ptx")].decode()
    assert f".target {max(chips)}" in ptx
    for name in names:
        assert f".entry {name}(" in ptx


def test_running_example_compiles_for_gpus():
    s = running_example()
    kernels = yasps.compiler.gpu.compile_scene(s)
    paths = {k.attribute for k in kernels.kernels}
    assert paths == set(yasps.compiler.gpu.scene_kernel_paths(s))
    # Every energy, with derivatives for those of the targets; the union's
    # kernels decode their members like the CPU's. The barrier over soft and
    # affine vertices keeps its projected Hessian factored (J and P).
    assert any(p.endswith("__hess_inner_proj") for p in paths)
    assert any(p.endswith("__ij") for p in paths)
    check_binaries(kernels, yasps.compiler.gpu.DEFAULT_CHIPS)
    for k in kernels.kernels:
        # Every buffer the kernel reads is an argument, the output among
        # them; inputs it does not read (the affine values behind a linear
        # map J) are left out of the launch.
        buffers = [i for kind, i in k.launch_params if kind == "buffer"]
        assert len(set(buffers)) == len(buffers), k.attribute
        assert all(2 <= i < 2 + len(k.arguments) for i in buffers), k.attribute
        out = 2 + [a.kind.name for a in k.arguments].index("out")
        assert out in buffers, k.attribute
        assert ("index", 0) in k.launch_params and ("index", 1) in k.launch_params


def test_demo_scene_compiles_for_gpus_and_caches():
    s = drop.build(1)[0]
    first = yasps.compiler.gpu.compile_scene(s)
    check_binaries(first, yasps.compiler.gpu.DEFAULT_CHIPS)
    assert not first.stats["from_disk"]
    again = yasps.compiler.gpu.compile_scene(s)
    assert again.stats["from_disk"]
    assert again.binaries == first.binaries


def test_an_f32_scene_compiles_to_f32_arithmetic_with_f64_buffers():
    """An f32 scene's device kernels compute in f32 (f32 multiplies,
    divisions and correctly rounded square roots in the PTX: not
    libdevice's default sqrt.approx.f32, yasps-precise-gpu-sqrt) and read
    and write the f64 buffers the device keeps: loads rounded
    (cvt.rn.f32.f64), results widened (cvt.f64.f32) before they are
    stored."""
    s = drop.build(1)[0]
    s.precision = "f32"
    kernels = yasps.compiler.gpu.compile_scene(s, chips=["sm_90"])
    check_binaries(kernels, ["sm_90"])
    ptx = kernels.binaries[("sm_90", "ptx")].decode()
    for instruction in ("mul.rn.f32", "div.rn.f32", "sqrt.rn.f32",
                        "cvt.rn.f32.f64", "cvt.f64.f32"):
        assert instruction in ptx, instruction
    assert "sqrt.approx" not in ptx


def test_projection_scratch_is_per_thread():
    """The eigensolver's scratch buffers live in the kernel (per thread),
    not on the host: the kernel takes only the loop's buffers."""
    s = yasps.scene("p")
    p = s.addMesh("m").addPrimitive("p", numInstances=4)
    h = p.addAttribute("h", rows=6, cols=6)
    p.addAttribute("proj", computed_attribute=h.project())
    kernels = yasps.compiler.gpu.compile_scene(s, ["@m::@p::@proj"], chips=["sm_90"],
                                      keep_ptx=False)
    k = kernels.kernel("@m::@p::@proj")
    assert [kind for kind, _ in k.launch_params].count("buffer") == 2
    assert list(kernels.binaries) == [("sm_90", "cubin")]


def test_the_gpu_solver_kernels_are_built_for_sm80_and_sm90():
    """The runtime's hand-written solver kernels (assembly, SpMV per block
    shape, block-Jacobi, PCG) are built into it as sm_80 and sm_90 cubins
    and PTX."""
    native = yasps.runtime.native.native()
    images = native.gpu_solver_images()
    names = set(native.gpu_solver_kernel_names())
    assert {"yasps_assemble", "yasps_spmv_3x3", "yasps_spmv_any",
            "yasps_pcg_scalar"} <= names
    assert set(images) == {("sm_80", "cubin"), ("sm_90", "cubin"),
                           ("sm_90", "ptx")}
    for chip in ("sm_80", "sm_90"):
        assert names <= elf_function_symbols(images[(chip, "cubin")])
    ptx = images[("sm_90", "ptx")].rstrip(b"\0").decode()
    for name in names:
        assert f".entry {name}(" in ptx


def test_every_generated_kernel_can_launch_with_its_block_size():
    """The launch-resource gate: ptxas' registers, stack and shared memory
    of every kernel of the running example and of the demo scene fit its
    block size on a multiprocessor, and its PTX entry takes the parameters
    its launch record passes. A kernel given too large a block, or a launch
    record one buffer short, is reported."""
    from yasps.compiler.gpu_resources import launch_problems, resource_usage
    for scene in (running_example(), drop.build(1)[0]):
        kernels = yasps.compiler.gpu.compile_scene(scene, chips=["sm_90"])
        usage = resource_usage(kernels.binaries[("sm_90", "ptx")], "sm_90")
        assert launch_problems(kernels, usage) == []
        assert all(u.registers > 0 for u in usage.values())
    heaviest = max(kernels.kernels, key=lambda k: usage[k.name].registers)
    heaviest.threads_per_block = 1024
    heaviest.launch_params = heaviest.launch_params[:-1]
    problems = launch_problems(kernels, usage)
    assert len(problems) == 2
    assert "registers x 1024 threads" in problems[0]
    assert "launch record passes" in problems[1]


def test_fixed_corotated_compiles_for_gpus_and_can_launch():
    """The sum of signed singular values (eight Laguerre steps, unrolled)
    lowers to the GPU like any other arithmetic, within the launch gate."""
    from yasps.compiler.gpu_resources import launch_problems, resource_usage
    from yasps.sim import (add_elastic_tets, add_free_vertices, box_tet_mesh,
                           lumped_masses)
    verts, tets = box_tet_mesh(1, 0.1)
    s = yasps.scene("fixed_corotated_gpu")
    m = s.addMesh("m")
    soft = add_free_vertices(m, verts, lumped_masses(verts, tets, 1000.0))
    add_elastic_tets(m, soft.x, verts, tets, 1.0, 1.0,
                     material="fixed_corotated")
    s.addMinimizeTarget(soft.x)
    kernels = yasps.compiler.gpu.compile_scene(s, chips=["sm_90"])
    check_binaries(kernels, ["sm_90"])
    usage = resource_usage(kernels.binaries[("sm_90", "ptx")], "sm_90")
    assert launch_problems(kernels, usage) == []
