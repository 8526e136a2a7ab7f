"""Kernels compiled ahead into the kernel store, run without the compiler
(``yasps.compiler.store``): a whole contact simulation with friction runs
from the store in a process where the compiler is switched off
(``YASPS_NO_COMPILER=1``, as on a runtime-only installation), on the CPU
and on the GPU backend's stand-in driver, to the positions of the compiled
run; a kernel missing from the store is a named error."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Dict

import ipctk
import numpy as np
import pytest

import yasps
from yasps.compiler import store
from yasps.errors import KernelNotCompiledError

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
FAKE_DRIVER = Path(os.environ.get("YASPS_BUILD_DIR", REPO / "build")) / \
    "runtime" / "test" / "libYaspsFakeCuda.so"


def run_scene(tmp: Path, out: str, *options: str,
              **env: str) -> Dict[str, np.ndarray]:
    """Runs store_scene.py with the cache and store under ``tmp``; returns
    what it wrote (nothing for a compile-only run)."""
    environment = dict(os.environ, YASPS_CACHE_DIR=str(tmp / "cache"),
                       YASPS_KERNEL_STORE=str(tmp / "store"))
    environment.update({"YASPS_BACKEND": "cpu", **env})
    done = subprocess.run([sys.executable, str(HERE / "store_scene.py"),
                           str(tmp / out), *options], env=environment,
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    path = tmp / out
    return dict(np.load(path)) if path.exists() else {}


def intersection_free(run: Dict[str, np.ndarray]) -> bool:
    """ipctk's verdict on the run's last world positions."""
    V = run["world"]
    faces = run["faces"]
    mesh = ipctk.CollisionMesh(V, ipctk.edges(faces), faces)
    return not ipctk.has_intersections(mesh, V)


@pytest.fixture(scope="module")
def compiled(tmp_path_factory) -> Path:
    """A folder whose store holds the scene's CPU kernels, and the
    compiled run's result (``compiled.npz``)."""
    tmp = tmp_path_factory.mktemp("store")
    run_scene(tmp, "compiled.npz", "--store", YASPS_STORE_KERNELS="1")
    return tmp


def test_a_stored_scene_runs_without_the_compiler(compiled):
    """The same frames from the store, with no compiler request, to the same
    bits: the shared libraries hold the very code the JIT ran."""
    reference = dict(np.load(compiled / "compiled.npz"))
    stored = run_scene(compiled, "stored.npz", YASPS_NO_COMPILER="1")
    assert json.loads(str(stored["requests"])) == {}
    assert np.array_equal(stored["world"], reference["world"])
    assert intersection_free(stored)
    # The scene moved: the boxes fell.
    start = run_scene(compiled, "none.npz", "--frames", "0",
                      YASPS_NO_COMPILER="1")
    assert np.abs(stored["world"] - start["world"]).max() > 1e-3


def test_a_kernel_missing_from_the_store_is_named(tmp_path, monkeypatch):
    monkeypatch.setenv("YASPS_KERNEL_STORE", str(tmp_path / "empty"))
    monkeypatch.setattr(yasps.compiler.cpu, "has_compiler", lambda: False)
    s = yasps.scene("not_stored")
    v = s.addMesh("m").addPrimitive("v", numInstances=2)
    x = v.addAttribute("x", rows=1)
    x.updateValue(np.array([[1.0], [2.0]]))
    s.addEnergy(v.addAttribute("e", computed_attribute=x * x))
    with pytest.raises(KernelNotCompiledError,
                       match=r"scene 'not_stored': the CPU kernel of "
                             r"@m::@v::@e is not in the kernel store .*"
                             r"yasps.compile\(scene, store=True\)"):
        s.evaluateEnergy()


def test_kernels_for_another_cpu_are_refused(tmp_path, monkeypatch):
    """A stored kernel that needs an instruction this CPU lacks is refused
    by name instead of crashing on an illegal instruction."""
    monkeypatch.setattr(store, "host_flags", lambda: ("avx",))
    record = {"format": store.STORE_FORMAT, "cpu": "x86-64-v4",
              "requires": ["avx", "avx512f"]}
    monkeypatch.setattr(store, "_read_record", lambda key: record)
    with pytest.raises(KernelNotCompiledError,
                       match=r"compiled for x86-64-v4, which needs avx512f"):
        store.load_cpu("ir", "", ["@m::@v::@e"], "elsewhere")


@pytest.mark.skipif(not FAKE_DRIVER.exists(),
                    reason=f"the stand-in driver {FAKE_DRIVER} is not built")
def test_gpu_kernels_compiled_ahead_run_a_simulation_on_the_stand_in(
        compiled):
    """GPU kernels compiled ahead for the stand-in driver's chip ("host")
    on a machine without a GPU; then, with the compiler off, the same
    frames on the GPU backend to the CPU's positions."""
    run_scene(compiled, "unused.npz", "--chips", "host",
              YASPS_STORE_KERNELS="1", YASPS_STORE_CHIPS="host")
    gpu = run_scene(compiled, "gpu.npz", YASPS_NO_COMPILER="1",
                    YASPS_BACKEND="gpu", YASPS_CUDA_LIBRARY=str(FAKE_DRIVER))
    reference = dict(np.load(compiled / "compiled.npz"))
    assert str(gpu["backend"]) == "gpu"
    assert json.loads(str(gpu["requests"])) == {}
    assert np.abs(gpu["world"] - reference["world"]).max() < 1e-9
    assert intersection_free(gpu)
