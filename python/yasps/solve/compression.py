"""Local Hessians compressed before their projection (paper 7.2): the rows
and columns of parameters that share a DoF are merged and UNION padding is
dropped, so each instance is projected as the k x k matrix it adds to the
global system, by a kernel for that size: compiled ahead for the sizes a
scene can meet (``yasps.compile``), else when it is first met. Runs on
the host."""

from __future__ import annotations

import functools
from typing import Dict, Tuple

import numpy as np

from ..compiler.params import ArgumentKind
from ..compiler.specs import KernelRequest
from ..frontend.scene import Scene
from ..ir import emit_scene
from ..runtime import cpu_backend
from ..runtime.cpu import launch
from ..runtime.native import native

_projectors: Dict[Tuple[int, str, str], tuple] = {}
#: The projected attribute of a projector's scene.
PROJECTOR_PATH = "@m::@p::@proj"


def compressed_sizes(dofs: np.ndarray) -> np.ndarray:
    """Distinct DoFs >= 0 per row of a DoF map (the runtime's count)."""
    return native().compressed_sizes(np.ascontiguousarray(dofs,
                                                          dtype=np.int64))


@functools.lru_cache(maxsize=None)
def projector_request(k: int, method: str, precision: str) -> KernelRequest:
    """The compiler request for the kernel projecting k x k symmetric
    matrices by ``method`` in ``precision`` (a scene of its own), which
    :func:`project_compressed` makes when it first meets size k: compiled
    ahead (``yasps.compile``), that request is served from memory."""
    s = Scene(f"yasps_project_{k}_{method}", precision)
    p = s.addMesh("m").addPrimitive("p", numInstances=1)
    h = p.addAttribute("h", rows=k, cols=k)
    p.addAttribute("proj", computed_attribute=h.project(method))
    return KernelRequest(emit_scene(s), (PROJECTOR_PATH,), s.name, "")


def _projector(k: int, method: str, precision: str):
    """A kernel projecting k x k symmetric matrices by ``method`` in
    ``precision``, compiled the first time this size is met (paper 7.2),
    unless compiled ahead, and cached."""
    key = (k, method, precision)
    if key not in _projectors:
        request = projector_request(k, method, precision)
        _projectors[key] = (cpu_backend().compile(
            request.ir, request.paths, request.name), PROJECTOR_PATH)
    return _projectors[key]


def project_compressed(dofs: np.ndarray, hess: np.ndarray, method: str,
                       threads: int, precision: str = "f64") -> np.ndarray:
    """Projected local Hessians, each projected as the k x k matrix it adds
    to the global system (repeated DoFs merged, padding dropped) and written
    back at the first parameter of each DoF. ``precision``: the float type
    the projection computes in (the energy's scene's)."""
    runtime = native()
    count, n = dofs.shape
    out = np.zeros((count, n, n))
    # Compression is f64 (an f32 scene's local Hessians are widened).
    hess = np.ascontiguousarray(hess, dtype=np.float64)
    for k, instances, matrices in runtime.compress_local_hessians(dofs, hess):
        if k == 0:
            continue
        kernels, path = _projector(int(k), method, precision)
        # The projector reads f64 and writes the scene's precision (f32
        # for f32 scenes), widened back for the expansion.
        projected = np.empty(matrices.size,
                             dtype=kernels.kernel(path).out_dtype)
        # Symmetric matrices: row- and column-major storage agree.
        given = {ArgumentKind.out: projected,
                 ArgumentKind.attr: np.ascontiguousarray(matrices).reshape(-1)}
        launch(kernels, path, len(instances),
               [given[a.kind] for a in kernels.kernel(path).arguments],
               threads)
        runtime.expand_local_hessians(
            dofs, int(k), instances,
            projected.astype(np.float64).reshape(matrices.shape), out)
    return out
