"""Process-wide settings of yasps.

- ``cache_dir``: where compiled kernels are kept between processes. From the
  environment variable ``YASPS_CACHE_DIR``; otherwise
  ``$XDG_CACHE_HOME/yasps`` or ``~/.cache/yasps``. ``None`` (or
  ``YASPS_CACHE_DIR=off``) keeps kernels in memory only.
- ``num_threads``: threads used to evaluate kernels on the CPU; 0 uses every
  core (or ``YASPS_NUM_THREADS`` if set). While ``ImplicitEuler.step`` or
  ``newton`` runs, NumPy's BLAS runs on one thread (its idle threads spin
  on the cores yasps' pool needs; :mod:`yasps.runtime.blas`).
- ``opt_level``: LLVM optimisation level of CPU kernels (0-3).
- ``backend``: ``"auto"`` (the GPU when one is usable, else the CPU),
  ``"cpu"`` or ``"gpu"``; from the environment variable ``YASPS_BACKEND``,
  else ``"auto"``. ``yasps.backend()`` names the active one (see
  ``yasps.backend`` module).
- ``simd_lanes``: CPU kernels evaluate this many instances at once, one per
  SIMD lane: their arithmetic runs on vectors, and a PSD projection's
  eigensolver works on that many matrices in lockstep. 0, the default, uses
  the host's vector width in doubles (8 with AVX-512, else 4), and twice
  that for kernels that PSD-project a matrix of at most 12x12 (two vectors
  of eigensolvers overlap their chains of square roots and divisions:
  17% faster on stable Neo-Hookean's 9x9); 1 evaluates one instance at a
  time. A width set here applies to every kernel.
- ``cpu_target``: the CPU that CPU kernels are compiled for, an LLVM CPU
  name (``"x86-64-v3"``: any x86 machine with AVX2 and FMA); ``None``, the
  default, compiles for this machine with every feature it has. For kernels
  compiled ahead into the kernel store and carried to another machine
  (``yasps.compile(scene, store=True)``, :mod:`yasps.compiler.store`). From
  ``YASPS_CPU_TARGET`` where set.
- ``separate_reduced_hessians``: where the reduced-space projection applies
  (paper 5.4), keep each local Hessian as its factors, the inner map J and
  the projected inner Hessian P, and form J^T P J only while assembling
  (paper 7.2, 10.9). Saves compile time and memory when the parameters far
  outnumber the inner variables (collision pairs on affine bodies, vertices
  driven by many cage points); costs some arithmetic during assembly.
  ``None``, the default, decides per energy (factors when they hold at most
  half the values of the dense local Hessian); ``True`` or ``False`` forces
  it.
- ``linear_map_projection``: where an energy reaches its parameters through
  a linear map with fewer entries (a tet's deformation gradient F: 9
  against 12 positions; a spring's edge vector: 3 against 6), project its
  Hessian in the map's entries, J^T P(d2E/dF2) J (paper 10.4, found by the
  compiler). PSD either way; where d2E/dF2 is indefinite the result
  differs from projecting the full Hessian. On by default; ``False``
  projects in the leaves' entries or the parameters, as before.
- ``slot_jacobians``: with factored local Hessians on the CPU, take J slot by
  slot from Jacobian tables of the sources (each UNION member's ``X__jac``
  over its own instances, the identity for targets), computed once per
  assembly and shared by every energy that reaches them, so that each
  instance stores only its inner gradient and P, whatever the widest UNION
  member (paper 7.1, 10.9, E.3.3). On by default; ``False`` stores the
  per-instance J, padded to the widest member (the GPU's path).
- ``compress_local_hessians``: before a full (not reduced-space) projection
  in assembly, merge the rows and columns of parameters that share a DoF
  and drop UNION padding, then project the k x k matrix with a kernel
  compiled for that size (paper 7.2). On by default.
- ``precision``: the float type derivative kernels compute in, ``"f64"``
  (the default) or ``"f32"``; a scene's own ``precision``
  (``yasps.scene(name, precision=...)``) overrides it. In f32 the local
  gradients, Hessians, PSD projections and placement indices of the
  Newton system are computed in single precision, with twice the SIMD
  lanes on the CPU. Values stay f64: ``compute()``, ``evaluateEnergy`` (the
  line search compares energies whose decrease near convergence is below
  f32's round-off) and the world positions collision detection reads. The
  buffers the runtime keeps (attributes, local derivatives, the global
  system) and the solve are f64, so the Newton update and its dot
  products are f64. ``docs/accuracy.md`` says what f32 costs in accuracy
  and where it breaks.
- ``hessian_storage``: the float type the CPU solve's products read the
  global Hessian's blocks in: ``"auto"`` (the default: f32 for systems of
  at least ``F32_PRODUCT_MIN_DOFS`` = 32,768 DoFs, f64 below), ``"f64"``
  or ``"f32"``. PCG's matrix-vector product is bound by reading the
  blocks; in f32 it reads half the bytes, while vectors, dot products, the
  preconditioner and the Newton update stay f64 (mixed precision). The
  solve is then of a matrix within f32's round-off of the assembled one,
  entry by entry. The GPU solve keeps f64 blocks (and warns once when
  ``"f32"`` is asked for).
- ``preconditioner``: PCG's preconditioner, ``"auto"`` (the default),
  ``"block-jacobi"`` (the inverses of the Hessian's diagonal blocks) or
  ``"multilevel"`` (the fine level's block-Jacobi added to a V-cycle over
  coarse levels of aggregated blocks,
  ``runtime/include/yasps/Runtime/Sparse/Multilevel.h``), on the CPU and the GPU.
  The multilevel one needs fewer iterations (several times fewer on the
  cloth and contact systems of larger scenes); each costs 1.2-1.7 of
  block-Jacobi's and every solve computes the levels' values first (9-11
  block-Jacobi iterations in all; their
  structure is kept while the Hessian's static structure stays), so it
  pays where block-Jacobi needs many iterations (fine meshes, stiff
  materials, contact). ``"auto"`` chooses per scene between them by
  bounded trials, each judged against a solve of the same system, and a
  fixed cost model (deterministic: iteration counts, not clocks;
  :mod:`yasps.solve.preconditioner_choice`);
  ``lastSolve["preconditioner"]`` says which one a solve used. On the
  GPU backend ``"auto"`` is block-Jacobi (the model is the CPU's).
  ``docs/benchmarks.md`` has the figures.
- ``gpu_derivatives``: on the GPU backend, ``minimizeEnergy`` computes the
  energies' local derivatives on the device, where assembly reads them
  (``yasps.gpu_derivatives``). Off, they are computed on the CPU and
  uploaded; the solve still runs on the device. On by default.

Each setting is checked when it is set (``ArgumentError`` for a value it
does not take). ``override(**settings)`` sets some for a ``with`` block
and restores them after it, also when the block raises::

    with yasps.config.override(precision="f32", num_threads=1):
        ...

``snapshot()`` gives every setting's value in ``SETTINGS``' order: the
caches of derivatives and plans are keyed by it.
"""

from __future__ import annotations

import os
import sys
import types
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator, Optional, Tuple

from .errors import ArgumentError


def _default_cache_dir() -> Optional[str]:
    value = os.environ.get("YASPS_CACHE_DIR")
    if value is not None:
        return None if value.lower() in ("", "off", "none", "0") else value
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return str(Path(base) / "yasps")


cache_dir: Optional[str] = _default_cache_dir()
num_threads: int = 0
opt_level: int = 3
backend: str = os.environ.get("YASPS_BACKEND", "auto").strip().lower() or "auto"
simd_lanes: int = 0
cpu_target: Optional[str] = os.environ.get("YASPS_CPU_TARGET") or None
separate_reduced_hessians: Optional[bool] = None
linear_map_projection: bool = True
slot_jacobians: bool = True
compress_local_hessians: bool = True
gpu_derivatives: bool = True
precision: str = "f64"

#: The values ``precision`` (and a scene's) may take.
PRECISIONS = ("f64", "f32")


hessian_storage: str = "auto"

#: The values ``hessian_storage`` may take.
HESSIAN_STORAGES = ("auto",) + PRECISIONS

#: From this many DoFs "auto" stores the product's blocks in f32. Measured
#: one thread, block-Jacobi, to relative residual 1e-4 on bench/cpu_peers.py's
#: systems: on bunny-19k (57,579 DoFs, its matrix larger than the caches) a
#: PCG iteration took 0.89-0.92 ms with f32 blocks against 1.01-1.06 ms with
#: f64 blocks, the same 55 iterations; on bunny-1.8k (5,607 DoFs) both took
#: 0.067-0.069 ms, so below the caches' size the rounding pass buys nothing.
F32_PRODUCT_MIN_DOFS = 1 << 15


def resolve_hessian_storage(dofs: Optional[int] = None) -> str:
    """The float type PCG's products read the blocks of a system of
    ``dofs`` DoFs in, "f64" or "f32": ``hessian_storage``, or for "auto"
    f32 from F32_PRODUCT_MIN_DOFS (f64 when ``dofs`` is not given). Raises
    ArgumentError for a value it does not take."""
    if hessian_storage not in HESSIAN_STORAGES:
        raise ArgumentError(f"hessian_storage must be one of "
                            f"{HESSIAN_STORAGES}, got {hessian_storage!r}")
    if hessian_storage != "auto":
        return hessian_storage
    return "f32" if dofs is not None and dofs >= F32_PRODUCT_MIN_DOFS \
        else "f64"


preconditioner: str = "auto"

#: The values ``preconditioner`` may take.
PRECONDITIONERS = ("auto", "block-jacobi", "multilevel")


def resolve_preconditioner() -> str:
    """``preconditioner``, checked: one of PRECONDITIONERS, else ValueError."""
    if preconditioner not in PRECONDITIONERS:
        raise ArgumentError(f"preconditioner must be one of {PRECONDITIONERS}, "
                            f"got {preconditioner!r}")
    return preconditioner


def resolve_precision(scene_precision: Optional[str]) -> str:
    """The precision a scene computes in: its own, else ``precision``.
    Raises ValueError for anything but "f64" or "f32"."""
    value = scene_precision if scene_precision is not None else precision
    if value not in PRECISIONS:
        raise ArgumentError(f"precision must be one of {PRECISIONS}, got {value!r}")
    return value


# ------------------------------------------------------------- validation

#: What each setting may be: checked when it is set, so that a wrong value
#: fails at the line that sets it, not later inside a compile or a solve.
_CHOICES = {"precision": PRECISIONS, "hessian_storage": HESSIAN_STORAGES,
            "preconditioner": PRECONDITIONERS,
            "backend": ("auto", "cpu", "gpu")}
_FLAGS = ("linear_map_projection", "slot_jacobians",
          "compress_local_hessians", "gpu_derivatives")
_COUNTS = {"num_threads": 0, "simd_lanes": 0, "opt_level": 0}


def _check(name: str, value) -> None:
    """Raises ArgumentError where ``value`` is not what setting ``name``
    takes."""
    wrong = None
    if name in _CHOICES and value not in _CHOICES[name]:
        wrong = f"one of {', '.join(map(repr, _CHOICES[name]))}"
    elif name in _FLAGS and not isinstance(value, bool):
        wrong = "True or False"
    elif name == "separate_reduced_hessians" and \
            not (value is None or isinstance(value, bool)):
        wrong = "None, True or False"
    elif name in _COUNTS and (isinstance(value, bool) or
                              not isinstance(value, int) or value < 0 or
                              (name == "opt_level" and value > 3)):
        wrong = ("a whole number from 0 to 3" if name == "opt_level"
                 else "a whole number >= 0")
    elif name == "cpu_target" and not (value is None or
                                       (isinstance(value, str) and value)):
        wrong = "an LLVM CPU name such as 'x86-64-v3', or None"
    elif name == "cache_dir" and not (value is None or
                                      isinstance(value, (str, os.PathLike))):
        wrong = "a folder (str or path) or None"
    if wrong is not None:
        raise ArgumentError(f"yasps.config.{name} must be {wrong}, got "
                            f"{value!r}")


#: Every setting, by name (what ``override`` takes).
SETTINGS = ("cache_dir", "num_threads", "opt_level", "backend", "simd_lanes",
            "cpu_target",
            "separate_reduced_hessians", "linear_map_projection",
            "slot_jacobians", "compress_local_hessians", "gpu_derivatives",
            "precision", "hessian_storage", "preconditioner")


def snapshot() -> Tuple[Tuple[str, object], ...]:
    """Every setting's current value, as (name, value) pairs in SETTINGS'
    order: what caches of kernels, plans and derivatives are keyed by."""
    module = sys.modules[__name__]
    return tuple((name, getattr(module, name)) for name in SETTINGS)


@contextmanager
def override(**settings) -> Iterator[None]:
    """Sets ``settings`` (each checked first: an unknown name or a bad value
    raises ``ArgumentError`` and changes nothing) for the ``with`` block,
    and restores their previous values after it."""
    unknown = sorted(set(settings) - set(SETTINGS))
    if unknown:
        raise ArgumentError(f"yasps.config has no setting {unknown[0]!r}; "
                            f"the settings are {', '.join(SETTINGS)}")
    for name, value in settings.items():
        _check(name, value)
    module = sys.modules[__name__]
    previous = {name: getattr(module, name) for name in settings}
    try:
        for name, value in settings.items():
            setattr(module, name, value)
        yield
    finally:
        for name, value in previous.items():
            setattr(module, name, value)


class _Config(types.ModuleType):
    """This module, its settings checked as they are set."""

    def __setattr__(self, name: str, value) -> None:
        _check(name, value)
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Config
