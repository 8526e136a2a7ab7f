"""The GPU backend: backend selection, the driver's status, device copies
that are uploaded only when their values change, and (on a machine with a
usable GPU) compute() on the GPU against the CPU.

Without a GPU the host side still runs against the runtime's stand-in
driver library (runtime/test/FakeCuda.cpp, which runs host images of the
generated kernels and the GPU solver's kernels on the host), in a
subprocess so that this process keeps its real driver status. The value
comparisons with the CPU are test_gpu_against_cpu.py, run here against the
stand-in."""

import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO, running_example

import yasps
import yasps.runtime.gpu
import yasps.runtime.native

STATUS = yasps.gpu_status()
needs_gpu = pytest.mark.skipif(
    not STATUS.usable, reason=f"no usable GPU: {STATUS.reason}")
no_gpu = pytest.mark.skipif(
    STATUS.usable, reason="this machine has a usable GPU")
HAS_PTXAS = shutil.which("ptxas", path="/usr/local/cuda/bin:/usr/bin") \
    is not None
FAKE_DRIVER = Path(os.environ.get("YASPS_BUILD_DIR", REPO / "build")) / \
    "runtime" / "test" / "libYaspsFakeCuda.so"


def run_python(script: str, **env: str) -> str:
    """Runs ``script`` in a fresh interpreter with ``env`` added; returns its
    stdout (and fails with its stderr if it fails)."""
    result = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(script)],
        env=dict(os.environ, PYTHONPATH=str(REPO / "python"), **env),
        capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    return result.stdout


def test_computed_values_are_dlpack_arrays_on_the_cpu(monkeypatch):
    monkeypatch.setattr(yasps.config, "backend", "cpu")
    s = running_example()
    r = s.bunny_affine.tets["positions"].compute()
    assert r.__dlpack_device__() == (1, 0)   # kDLCPU
    view = np.from_dlpack(r)
    assert view.shape == r.value.shape and np.shares_memory(view, r.value)


@no_gpu
def test_without_a_gpu_the_cpu_is_used_and_gpu_says_why(monkeypatch):
    assert yasps.backend() == "cpu"
    assert STATUS.reason and STATUS.devices == ()
    monkeypatch.setattr(yasps.config, "backend", "gpu")
    with pytest.raises(yasps.BackendError, match="cannot be used: .*libcuda"):
        yasps.backend()
    monkeypatch.setattr(yasps.config, "backend", "cpu")
    assert yasps.backend() == "cpu"
    with pytest.raises(yasps.ArgumentError, match="backend must be one of"):
        monkeypatch.setattr(yasps.config, "backend", "tpu")


def test_a_gpu_without_the_toolchain_falls_back_to_the_cpu(monkeypatch):
    """A usable GPU is not enough: without ptxas (or the runtime's solver
    kernels) "auto" stays on the CPU and "gpu" says what is missing."""
    module = sys.modules["yasps.runtime.backend"]
    monkeypatch.setattr(module, "gpu_status", lambda: module.GpuStatus(
        True, "", (("Some GPU", "sm_90", 1 << 30),)))
    monkeypatch.setattr(module.shutil, "which", lambda name, path=None: None)
    monkeypatch.setattr(yasps.config, "backend", "auto")
    assert yasps.backend() == "cpu"
    monkeypatch.setattr(yasps.config, "backend", "gpu")
    with pytest.raises(yasps.BackendError, match="ptxas, which builds GPU "
                       "kernels, was not found"):
        yasps.backend()


def test_environment_variable_chooses_the_backend():
    out = run_python("""
        import yasps
        print(yasps.config.backend, yasps.backend())
    """, YASPS_BACKEND="CPU")
    assert out.split() == ["cpu", "cpu"]


@pytest.mark.skipif(not FAKE_DRIVER.exists(),
                    reason=f"the stand-in driver {FAKE_DRIVER} is not built")
@pytest.mark.skipif(not HAS_PTXAS, reason="the CUDA toolkit (ptxas) is not "
                    "installed")
def test_device_copies_are_uploaded_only_when_values_change():
    out = run_python("""
        import numpy as np, yasps
        assert yasps.backend() == "gpu", yasps.gpu_status()
        assert yasps.gpu_status().devices == (("Fake GPU", "sm_90", 8 << 30),)
        s = yasps.scene("g")
        m = s.addMesh("m")
        v = m.addPrimitive("v", numInstances=4)
        e = m.addPrimitive("e", numInstances=2)
        x = v.addAttribute("x", rows=3, cols=1)
        x.updateValue(np.arange(12.0).reshape(4, 3))
        conn = e.addConnectivity("e2v", v, [[0, 1], [2, 3]], 2)
        ends = e.addAttribute("ends", through=conn, source=x)
        length = e.addAttribute("length",
                                computed_attribute=(ends.row(1) - ends.row(0)).norm())
        def uploads():
            r = length.compute()
            assert r.stats["backend"] == "gpu" and r.stats["device"] == "sm_90"
            assert r.value.shape == (2, 1, 1)
            return sorted(k for k, _ in r.stats["uploaded"])
        print(uploads())                # first use: both
        print(uploads())                # unchanged: nothing
        x.updateValue(np.ones((4, 3)))  # new values: x only
        print(uploads())
        conn.updateConnectivity([[1, 0], [3, 2]])
        print(uploads())
        print(uploads())
        # The result is a DLPack array on the device (kDLCUDA = 2), viewed
        # without a copy; views cannot reach past their buffer.
        r = length.compute()
        print(r.__dlpack_device__(), type(r.__dlpack__()).__name__)
        buffer = yasps.runtime.native.native().gpu_allocate(
            yasps.runtime.gpu.session().device, 2)
        try:
            buffer.dlpack_view([3], [1])
        except IndexError as err:
            print("IndexError", "reaches element 2" in str(err))
    """, YASPS_CUDA_LIBRARY=str(FAKE_DRIVER))
    assert out.splitlines() == ["['attr', 'conn']", "[]", "['attr']",
                                "['conn']", "[]", "(2, 0) PyCapsule",
                                "IndexError True"]


MINIMIZE_ON_BOTH = """
    import sys
    import numpy as np, yasps
    sys.path.insert(0, %r)
    from test_minimize import soft_box, mixed_scene

    # Derivatives on the CPU, uploaded for the GPU solve (with GPU
    # derivatives: test_gpu_against_cpu.py).
    yasps.config.gpu_derivatives = False

    def solve(scene, backend, **kw):
        yasps.config.backend = backend
        out = scene.minimizeEnergy(tolerance=1e-12, **kw)
        assert scene.lastSolve["backend"] == backend
        return np.concatenate([a.reshape(-1) for a in out]), scene.lastSolve

    def compare(scene, **kw):
        cpu, cpu_info = solve(scene, "cpu", **kw)
        gpu, gpu_info = solve(scene, "gpu", **kw)
        err = np.abs(gpu - cpu).max() / np.abs(cpu).max()
        print(err < 1e-9, abs(gpu_info["iterations"] - cpu_info["iterations"]) <= 1)

    box = soft_box()
    compare(box)
    # The GPU's PCG stops by every rule the CPU's does.
    compare(box, stopping="energy_norm")
    compare(box, stopping="preconditioned")
    n = box.m.v.numInstances
    compare(box, fixed=[np.arange(n) %% 3 == 0])
    s, pp, p2v, *_ = mixed_scene([[0, 3], [1, 4]])
    compare(s)
    for pairs in ([[2, 4]], [[0, 1], [2, 3], [1, 4]]):
        pp.updateNumInstances(len(pairs))
        p2v.updateConnectivity(np.array(pairs, dtype=np.int64))
        compare(s)
    yasps.config.separate_reduced_hessians = True
    compare(s)
    yasps.config.backend = "gpu"
    try:
        box.minimizeEnergy(tolerance=1e-14, maxIterations=1)
    except yasps.SolverError as err:
        print("after 1 iterations" in str(err), err.solution[0].shape == (n, 3, 1))
"""


GPU_DERIVATIVES = """
    import sys
    import numpy as np, yasps
    sys.path.insert(0, %r)
    from test_minimize import soft_box
    box = soft_box()

    def solve(backend):
        yasps.config.backend = backend
        (dx,) = box.minimizeEnergy(tolerance=1e-12)
        return dx

    def same():
        cpu, gpu = solve("cpu"), solve("gpu")
        info = box.lastSolve
        return (info["backend"], info["energiesDifferentiatedOnGpu"],
                np.abs(gpu - cpu).max() <= 1e-9 * np.abs(cpu).max())

    yasps.config.compress_local_hessians = False
    print(*same())
    # Once warm, a Newton iteration allocates no device memory, even with
    # new positions.
    import ctypes
    fake = ctypes.CDLL(%r)
    x = box.m.v["x"]
    counts = []
    yasps.config.backend = "gpu"
    for step in range(3):
        x.updateValue(x.value[:, :, 0] + 0.01)
        box.minimizeEnergy()
        counts.append(fake.fakeCudaAllocations())
    print(counts[2] - counts[1])
    # Compression, and projection of the elastic energy on x rather than F.
    yasps.config.compress_local_hessians = True
    print(*same())
    yasps.config.linear_map_projection = False
    print(*same())
"""


@pytest.mark.skipif(not FAKE_DRIVER.exists(),
                    reason=f"the stand-in driver {FAKE_DRIVER} is not built")
@pytest.mark.skipif(not HAS_PTXAS, reason="the CUDA toolkit (ptxas) is not "
                    "installed")
def test_gpu_derivatives_feed_the_gpu_assembly():
    """With config.gpu_derivatives, the derivative and index kernels are
    compiled for the device and launched there (on the stand-in: their host
    images), and assembly reads their device outputs: the direction is the
    CPU's, with and without compression, and a warm Newton iteration
    allocates nothing."""
    out = run_python(GPU_DERIVATIVES % (str(REPO / "python" / "tests"),
                                        str(FAKE_DRIVER)),
                     YASPS_CUDA_LIBRARY=str(FAKE_DRIVER))
    assert out.split() == ["gpu", "2", "True", "0"] + ["gpu", "2", "True"] * 2


@pytest.mark.skipif(not FAKE_DRIVER.exists(),
                    reason=f"the stand-in driver {FAKE_DRIVER} is not built")
@pytest.mark.skipif(not HAS_PTXAS, reason="the CUDA toolkit (ptxas) is not "
                    "installed")
@pytest.mark.parametrize("selection", ["not assembled and not newton and "
                                       "not paper", "assembled or newton",
                                       "paper"])
def test_the_gpu_comparisons_pass_on_the_stand_in_driver(selection):
    """test_gpu_against_cpu.py, which needs a usable GPU backend, run
    against the stand-in driver: the generated kernels' host images
    against the CPU backend, f64 and f32, and a broken kernel caught (in
    three parts, which test workers run side by side)."""
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
         "-p", "no:randomly", "-p", "no:xdist", "-k", selection,
         str(Path(__file__).parent / "test_gpu_against_cpu.py")],
        env=dict(os.environ, PYTHONPATH=str(REPO / "python"),
                 YASPS_CUDA_LIBRARY=str(FAKE_DRIVER)),
        capture_output=True, text=True, cwd=Path(__file__).parent)
    assert result.returncode == 0, result.stdout[-4000:] + result.stderr
    assert "skipped" not in result.stdout, result.stdout[-2000:]


# --- on a GPU only --------------------------------------------------------

@needs_gpu
def test_gpu_results_are_dlpack_views_of_device_memory(monkeypatch):
    torch = pytest.importorskip("torch")
    monkeypatch.setattr(yasps.config, "backend", "gpu")
    s = running_example()
    r = s.bunny_affine.tets["positions"].compute()
    on_device = torch.from_dlpack(r)
    assert on_device.is_cuda
    assert np.array_equal(on_device.cpu().numpy(), r.value)


GPU_COMPILES_ONCE = """
    import sys
    import yasps
    import yasps.runtime.gpu as gpu
    sys.path.insert(0, %r)
    from test_minimize import mixed_scene
    yasps.config.compress_local_hessians = False
    compiled = []
    original = gpu.compile_ir
    def counting(ir, paths, *args, **kwargs):
        compiled.extend(paths)
        return original(ir, paths, *args, **kwargs)
    gpu.compile_ir = counting
    import numpy as np
    s, pp, *_ = mixed_scene([[0, 3], [1, 4]])
    # Fixed targets: the path to the solve is what this checks.
    fixed = [np.ones(t.owner.numInstances, dtype=bool)
             for t in s.minimizeTargets]
    # Requests of different kernel sets, in both orders, twice over.
    for _ in range(2):
        for energy in s.energies:
            energy.compute()
        s.minimizeEnergy(fixed=fixed)
        s.evaluateEnergy()
        for energy in s.energies:
            s.energyDerivatives(energy)
    print(len(compiled) > 0, len(compiled) == len(set(compiled)),
          s.lastSolve["backend"])
"""


@pytest.mark.skipif(not FAKE_DRIVER.exists(),
                    reason=f"the stand-in driver {FAKE_DRIVER} is not built")
@pytest.mark.skipif(not HAS_PTXAS, reason="the CUDA toolkit (ptxas) is not "
                    "installed")
def test_gpu_kernels_are_compiled_once_per_process():
    """The GPU session compiles, per request, only the kernels no earlier
    request compiled: compute(), minimizeEnergy, evaluateEnergy and
    energyDerivatives share them (on the stand-in driver)."""
    out = run_python(GPU_COMPILES_ONCE % str(REPO / "python" / "tests"),
                     YASPS_CUDA_LIBRARY=str(FAKE_DRIVER))
    assert out.split() == ["True", "True", "gpu"], out


@pytest.mark.skipif(not FAKE_DRIVER.exists(),
                    reason=f"the stand-in driver {FAKE_DRIVER} is not built")
@pytest.mark.skipif(not HAS_PTXAS, reason="the CUDA toolkit (ptxas) is not "
                    "installed")
def test_huge_outputs_on_the_gpu_are_yasps_errors_after_the_input_checks():
    """As on the CPU: 10^9 instances without values are reported as missing
    values before any device memory is allocated, and an output the device
    cannot hold (the stand-in refuses more than 1 GiB) is a SceneError naming
    the attribute and the bytes, with the driver's reason."""
    out = run_python("""
        import ctypes, os
        import numpy as np, yasps
        fake = ctypes.CDLL(os.environ["YASPS_CUDA_LIBRARY"])
        assert yasps.backend() == "gpu", yasps.gpu_status()
        s = yasps.scene("huge")
        m = s.addMesh("m")
        p = m.addPrimitive("p", numInstances=10 ** 9)
        x = p.addAttribute("x", rows=3)
        doubled = p.addAttribute("d", computed_attribute=2.0 * x)
        before = fake.fakeCudaAllocations()
        try:
            doubled.compute()
        except yasps.ValueUpdateError as err:
            print("missing", "has no values" in str(err),
                  fake.fakeCudaAllocations() == before)
        q = m.addPrimitive("q", numInstances=10 ** 8)
        one = q.addAttribute("one", computed_attribute=yasps.constant(
            np.ones((3, 1))) * 1.0)
        try:
            one.compute()
        except yasps.SceneError as err:
            print(str(err).split(" on the GPU: ")[0])
            print("out of GPU memory" in str(err))
    """, YASPS_CUDA_LIBRARY=str(FAKE_DRIVER))
    assert out.splitlines() == [
        "missing True True",
        "@m::@q::@one: 100000000 instances of 3x1 doubles need "
        "2,400,000,000 bytes", "True"]
