"""What each generated GPU kernel needs at launch, and whether it fits.

A kernel that compiles can still fail to launch: too many registers for
its block size (a block's threads share the multiprocessor's 64K
registers), more static shared memory than a block may have, or a launch
record whose parameters do not match the entry's. None of that shows
without a GPU unless it is measured, so this reads ``ptxas -v`` on the
kernels' PTX (the same ptxas that makes the cubins) and checks each
kernel's registers, stack and shared memory against its block size, and
its PTX parameters against its launch record (:attr:`GpuKernel
.launch_params`: an index or constant is one parameter, a buffer a memref
descriptor of five).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from typing import Dict, List

from ..frontend.errors import IRError
from .gpu import GpuKernels

#: Registers of one multiprocessor (sm_80 and sm_90), shared by a block's
#: threads, and the most one thread may use.
REGISTERS_PER_BLOCK = 65536
REGISTERS_PER_THREAD = 255
#: Static shared memory one block may declare (dynamic memory aside).
SHARED_PER_BLOCK = 48 * 1024
#: The most threads a block may have.
THREADS_PER_BLOCK = 1024
#: PTX parameters of each launch-record entry kind.
PARAMS_OF_KIND = {"index": 1, "constant": 1, "buffer": 5}


@dataclass
class KernelResources:
    """ptxas' account of one entry point."""
    registers: int
    stack: int      #: bytes of stack frame per thread
    shared: int     #: bytes of static shared memory per block
    params: int     #: parameters of the PTX entry


def ptxas_path() -> str:
    """The CUDA toolkit's ptxas ($CUDA_ROOT/bin, /usr/local/cuda/bin or
    PATH)."""
    roots = [os.environ.get("CUDA_ROOT"), "/usr/local/cuda"]
    path = os.pathsep.join([f"{r}/bin" for r in roots if r]
                           + [os.environ.get("PATH", "")])
    found = shutil.which("ptxas", path=path)
    if found is None:
        raise IRError("gpu_resources: the CUDA toolkit's ptxas was not found")
    return found


def _entry_params(ptx: str) -> Dict[str, int]:
    """The number of parameters of each ``.entry`` of the PTX."""
    counts = {}
    for match in re.finditer(r"\.entry\s+(\w+)\s*\((.*?)\)", ptx, re.S):
        counts[match.group(1)] = match.group(2).count(".param")
    return counts


def resource_usage(ptx: bytes, chip: str) -> Dict[str, KernelResources]:
    """Each entry point's registers, stack, shared memory and parameters,
    by ``ptxas -v`` on ``ptx`` for ``chip`` (as the cubin was made)."""
    text = ptx.decode()
    with tempfile.TemporaryDirectory() as scratch:
        path = os.path.join(scratch, "kernels.ptx")
        with open(path, "w") as f:
            f.write(text)
        run = subprocess.run([ptxas_path(), "-v", "--gpu-name", chip, path,
                              "-o", os.devnull], capture_output=True,
                             text=True)
    if run.returncode:
        raise IRError(f"gpu_resources: ptxas failed: {run.stderr.strip()}")
    params = _entry_params(text)
    usage: Dict[str, KernelResources] = {}
    name = None
    for line in run.stderr.splitlines():
        entry = re.search(r"Compiling entry function '(\w+)'", line)
        if entry:
            name = entry.group(1)
            usage[name] = KernelResources(0, 0, 0, params.get(name, -1))
            continue
        if name is None:
            continue
        frame = re.search(r"(\d+) bytes stack frame", line)
        if frame:
            usage[name].stack = int(frame.group(1))
        registers = re.search(r"Used (\d+) registers", line)
        if registers:
            usage[name].registers = int(registers.group(1))
        shared = re.search(r"(\d+) bytes smem", line)
        if shared:
            usage[name].shared = int(shared.group(1))
    return usage


def launch_problems(kernels: GpuKernels,
                    usage: Dict[str, KernelResources]) -> List[str]:
    """Why a kernel of ``kernels`` could not launch with its block size or
    its launch record (one sentence each; empty if every one can)."""
    problems = []
    for k in kernels.kernels:
        found = usage.get(k.name)
        if found is None:
            problems.append(f"{k.name}: not an entry of the PTX")
            continue
        threads = k.threads_per_block
        if threads > THREADS_PER_BLOCK:
            problems.append(f"{k.name}: {threads} threads per block, more "
                            f"than {THREADS_PER_BLOCK}")
        if found.registers > REGISTERS_PER_THREAD or \
                found.registers * threads > REGISTERS_PER_BLOCK:
            problems.append(f"{k.name}: {found.registers} registers x "
                            f"{threads} threads exceed the "
                            f"{REGISTERS_PER_BLOCK} of a multiprocessor")
        if found.shared > SHARED_PER_BLOCK:
            problems.append(f"{k.name}: {found.shared} bytes of shared "
                            f"memory, more than {SHARED_PER_BLOCK}")
        wanted = sum(PARAMS_OF_KIND[kind] for kind, _ in k.launch_params)
        if found.params != wanted:
            problems.append(f"{k.name}: the PTX entry takes {found.params} "
                            f"parameters, its launch record passes {wanted}")
    return problems
