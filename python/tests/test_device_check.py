"""The GPU check script runs here as a dry run on the stand-in driver:
every step within its limit, a summary a GPU run would print (each step's
verdict and time, the measured lines) and the archive of logs, with what
only a GPU can run marked as left out; the kit's runtime-only build and
its whole simulations from the kernel store included. A GPU window then
does not fail on the script itself."""

import os
import re
import shutil
import subprocess
import tarfile

import pytest

from conftest import REPO

pytestmark = pytest.mark.skipif(
    shutil.which("ptxas", path="/usr/local/cuda/bin:/usr/bin") is None,
    reason="the kit's kernels need the CUDA toolkit's ptxas")


def test_device_check_dry_run_prints_the_summary(tmp_path):
    build = os.environ.get("YASPS_BUILD_DIR", str(REPO / "build"))
    kit, out = tmp_path / "kit", tmp_path / "out"
    # Step limits far beyond a step's seconds: CI shares its machine.
    # The stand-in's chip only (no ptxas), and this machine's packages.
    env = dict(os.environ, KIT_DIR=str(kit), BUILD_DIR=build,
               STEP_LIMIT="3600", KIT_CHIPS="host", KIT_WHEELS="none",
               WORK_DIR=str(tmp_path / "work"))
    made = subprocess.run(["bash", str(REPO / "scripts" / "device_kit.sh")],
                          env=env, capture_output=True, text=True)
    assert made.returncode == 0, made.stderr[-2000:]
    run = subprocess.run(["bash", str(REPO / "scripts" / "device_check.sh"),
                          "--dry-run", str(kit), str(out)], env=env,
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-3000:]
    summary = (out / "summary.txt").read_text()
    for step in ("runtime unit tests", "SpMV, assembly and PCG",
                 "stable Neo-Hookean kernels (yasps)",
                 "one Newton iteration of the bunny",
                 "runtime-only build (no LLVM or MLIR)",
                 "whole simulations (GPU beside CPU)"):
        line = next(l for l in summary.splitlines() if l.startswith(step))
        assert " ok " in line, line
    for step in ("cuSPARSE", "with PyTorch and JAX", "compute-sanitizer"):
        line = next(l for l in summary.splitlines() if step in l)
        assert "skipped in a dry run" in line, line
    assert "GPU SpMV" in summary and "[  PASSED  ]" in summary
    # The demo's first frames from the kit's store, on the runtime-only
    # build: the stand-in's positions within round-off of the CPU's.
    sim = re.search(r"^sim demo: 2 frames, .* positions within (\S+) of the "
                    r"CPU's$", summary, re.MULTILINE)
    assert sim is not None, summary
    assert float(sim.group(1)) < 1e-9
    assert ", 0 intersecting;" in summary
    # The runtime-only extension links neither LLVM nor MLIR, and the kit
    # carries no library of theirs.
    module = next((tmp_path / "work" / "build" / "python" / "yasps")
                  .glob("_yasps_runtime*.so"))
    linked = subprocess.run(["ldd", str(module)], capture_output=True,
                            text=True).stdout
    assert "LLVM" not in linked and "MLIR" not in linked, linked
    assert not [p for p in kit.rglob("*") if "libLLVM" in p.name or
                "libMLIR" in p.name]
    # The single logs went into the archive.
    with tarfile.open(out / "logs.tar.gz") as logs:
        names = set(logs.getnames())
    assert {"gtest.log", "spmv.log", "kernels.log", "newton.log"} <= names
    assert sorted(p.name for p in out.iterdir()) == ["logs.tar.gz",
                                                     "summary.txt"]
