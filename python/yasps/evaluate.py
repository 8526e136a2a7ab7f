"""Evaluating attributes with compiled CPU kernels (``attr.compute()``).

The scene is emitted as IR, the attribute's kernel is compiled (or found in
the in-memory or on-disk cache), and the runtime runs it over all instances of
the attribute's owner with the stored values, connectivities and union
offsets as buffers. Intermediate attributes are never stored.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Tuple

import numpy as np

from . import compiler, config
from .backend import backend
from .attribute import Attribute
from .emit import emit_scene
from .errors import SceneError, ValueUpdateError
from .scene import Connectivity, Entity, PrimitiveUnion, Scene
from .values import from_column_major

#: Name under which an unnamed expression is evaluated.
_TEMPORARY = "__yasps_compute"


class ComputedValue:
    """The result of :meth:`Attribute.compute`: ``value``, an ``(N, rows,
    cols)`` NumPy array, and ``stats``.

    It is also a DLPack array of the same values (``torch.from_dlpack(r)``,
    ``cupy.from_dlpack(r)``, ``np.from_dlpack(r)``): on the GPU backend a
    view of the result in device memory, without a copy; on the CPU the
    NumPy array. On the GPU, ``value`` is copied back on first use only."""

    def __init__(self, attribute: Attribute, value: Optional[np.ndarray],
                 stats: dict, device: object = None,
                 shape: Tuple[int, int, int] = (0, 0, 0)):
        self.attribute = attribute
        self._value = value
        #: The GPU output (column-major per instance) and its (N, rows,
        #: cols), when computed on the GPU.
        self._device = device
        self._shape = shape
        #: How the kernel was obtained: cache hits and compile times.
        self.stats = stats

    @property
    def value(self) -> np.ndarray:
        """The values, shape ``(N, rows, cols)`` (copied from the GPU the
        first time they are read)."""
        if self._value is None:
            count, rows, cols = self._shape
            host = np.empty(count * rows * cols, dtype=np.float64)
            self._device.download(host)
            self._value = from_column_major(host, rows, cols, copy=False)
        return self._value

    def _dlpack_source(self):
        if self._device is None:
            return self.value
        count, rows, cols = self._shape
        # Entry (i, r, c) lies at i * rows * cols + c * rows + r.
        return self._device.dlpack_view([count, rows, cols],
                                        [rows * cols, 1, rows])

    def __dlpack__(self, **kwargs):
        return self._dlpack_source().__dlpack__(**kwargs)

    def __dlpack_device__(self):
        return self._dlpack_source().__dlpack_device__()

    def __repr__(self) -> str:
        where = "GPU" if self._device is not None else "CPU"
        return (f"<yasps.ComputedValue of {self.attribute.describe()} on the "
                f"{where}: {self._shape if self._value is None else self.value.shape}>")


def _resolve(scene: Scene, path: str):
    """The object a scene-relative path such as ``@m::@v::@x`` names."""
    node = scene
    for name in path.split("::"):
        node = node._symbols[name.lstrip("@")]
    return node


def target_dof_offsets(scene: Scene) -> np.ndarray:
    """The first global DoF of each minimisation target, in order: targets
    one after another, instance after instance (paper appendix A.1)."""
    sizes = [t.owner.numInstances * t.rows * t.cols
             for t in scene.minimizeTargets]
    return np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64) \
        if sizes else np.zeros(0, dtype=np.int64)


def _buffer(scene: Scene, kind: str, path: str, out: np.ndarray) -> np.ndarray:
    if kind == "out":
        return out
    if kind == "dof_offsets":
        return target_dof_offsets(scene)
    target = _resolve(scene, path)
    if kind == "attr":
        if target._values is None:
            raise ValueUpdateError(
                f"{target.describe()} has no values for the current "
                f"{target.owner.numInstances} instances; call updateValue")
        return target._values
    if kind == "conn":
        assert isinstance(target, Connectivity)
        if target._indices is None:
            raise SceneError(f"{target.describe()} has no indices for the "
                             f"current {target.source.numInstances} instances; "
                             "call updateConnectivity")
        # The kernel trusts these indices: a target that shrank since they
        # were set (a dynamic primitive) must not be read out of bounds.
        bound = target.target.numInstances
        if target._indices.size and int(target._indices.max()) >= bound:
            raise SceneError(f"{target.describe()} refers to instance "
                             f"{int(target._indices.max())} of "
                             f"{target.target.describe()}, which now has "
                             f"{bound}; call updateConnectivity")
        return target._indices
    if kind == "offsets":
        assert isinstance(target, PrimitiveUnion)
        return np.ascontiguousarray(target.offsets, dtype=np.int64)
    raise AssertionError(f"unknown kernel argument kind {kind!r}")


#: Compiled libraries by (IR text, attributes, pipeline, settings): a scene
#: evaluated again with the same structure skips parsing, passes and the
#: kernel cache lookup. Instance counts are part of the IR text, so a dynamic
#: primitive that changes size falls through to the compiler's own cache,
#: which is keyed by the kernels alone.
_libraries: Dict[tuple, object] = {}


def _compile(ir: str, paths: List[str], scene: Scene, pipeline: str = ""):
    """The compiled library and how it was obtained (its stats)."""
    key = (ir, tuple(paths), pipeline, config.cache_dir, config.opt_level,
           config.simd_lanes)
    library = _libraries.get(key)
    if library is not None:
        return library, dict(library.stats, from_memory=True, from_disk=False,
                             lower_seconds=0.0, codegen_seconds=0.0)
    native = compiler._module()
    library = native.compile_cpu(ir, paths, config.cache_dir or "",
                                 config.opt_level, scene.name, pipeline,
                                 config.simd_lanes)
    _libraries[key] = library
    return library, dict(library.stats)


def compute(attr: Attribute, threads: int = None) -> ComputedValue:
    """Evaluates ``attr`` on every instance of its owner."""
    owner = attr.owner
    if owner is None:
        raise SceneError(f"{attr.describe()} belongs to no entity; add it to "
                         "one with addAttribute(name, computed_attribute=...)")
    scene = owner.scene
    extra: Dict[Entity, List[Tuple[str, Attribute]]] = {}
    target = attr
    if not attr.isNamed:
        extra = {owner: [(_TEMPORARY, attr)]}
        path = "::".join("@" + n for n in owner.path + [_TEMPORARY])
    else:
        path = "::".join("@" + n for n in owner.path + [attr.name])
    ir = emit_scene(scene, locations=True, extra=extra)
    count = owner.numInstances
    if backend() == "gpu":
        out, stats = _compute_on_gpu(scene, ir, path, count,
                                     count * target.rows * target.cols)
        return ComputedValue(attr, None, stats, out,
                             (count, target.rows, target.cols))
    native = compiler._module()
    try:
        library, stats = _compile(ir, [path], scene)
    except native.IRError as err:
        raise compiler.IRError(str(err)) from None
    arguments = dict(library.kernels)[path]
    out = np.empty(count * target.rows * target.cols, dtype=np.float64)
    buffers = [_buffer(scene, kind, p, out) for kind, p in arguments]
    library.launch(path, count, buffers,
                   config.num_threads if threads is None else threads)
    # A view of the fresh output buffer: no copy, nobody else holds it.
    return ComputedValue(attr, from_column_major(out, target.rows, target.cols,
                                                 copy=False), stats)


def _compute_on_gpu(scene: Scene, ir: str, path: str, count: int,
                    size: int) -> Tuple[object, dict]:
    """Runs the kernel of ``path`` on ``count`` instances on the GPU
    session's device: its output, a device buffer of ``size`` values, and
    the stats."""
    from .gpu_runtime import session

    gpu = session()
    kernels = gpu.kernels(ir, path, scene.name)
    uploads = len(gpu.uploads)
    out = run_on_gpu(gpu, kernels, scene, path, count, size)
    stats = dict(kernels.stats, backend="gpu", device=gpu.chip,
                 uploaded=gpu.uploads[uploads:])
    return out, stats


def run_on_gpu(gpu, kernels, scene: Scene, path: str, count: int,
               size: int, out=None):
    """Launches the kernel of ``path`` on ``count`` instances on the GPU
    session ``gpu``, its inputs device copies of the scene's stored values;
    returns its output, a device buffer of ``size`` values (``out`` if
    given)."""
    kernel = kernels.kernel(path)
    if out is None:
        out = compiler._module().gpu_allocate(gpu.device, size)
    buffers = []
    for kind, p in kernel.arguments:
        if kind == "out":
            buffers.append(out)
            continue
        source = _resolve(scene, p) if kind in ("attr", "conn") else None
        buffers.append(gpu.copy_of(kind, p, source,
                                   _buffer(scene, kind, p, None)))
    gpu.launch(kernels, path, count, buffers)
    return out


#: Passes that turn energies into their local derivatives (docs/passes.md).
DIFFERENTIATION_PIPELINE = ("yasps-inline-reads,canonicalize,cse,"
                            "yasps-differentiate,yasps-generate-indices")


def differentiation_pipeline() -> str:
    """DIFFERENTIATION_PIPELINE with the options of ``config``."""
    if config.separate_reduced_hessians:
        return DIFFERENTIATION_PIPELINE.replace(
            "yasps-differentiate",
            "yasps-differentiate{separate-reduced-hessians=true}")
    return DIFFERENTIATION_PIPELINE


class ParamSlot:
    """A group of an energy's local parameters (one entry of
    ``yasps.params``): the entries of a target read directly, or, for one
    instance gathered by a JOIN or decoded from a UNION, the parameters of
    the attribute found there (recursively, padded to ``width``)."""

    def __init__(self, kind: str, fields: list, owner: Entity,
                 derivatives: "_ParamResolver"):
        self.kind = kind
        self.fields = fields
        self.owner = owner
        self._resolver = derivatives

    @property
    def width(self) -> int:
        if self.kind == "read":
            target = _resolve(self._resolver.scene, self.fields[1])
            return target.rows * target.cols
        return int(self.fields[-1])

    def locations(self, i: int) -> list:
        """(target attribute, instance, entry) of each parameter of this
        group for energy instance ``i``; None for UNION padding."""
        scene = self._resolver.scene
        if self.kind == "read":
            target = _resolve(scene, self.fields[1])
            inst = i if target.owner is self.owner else 0
            return [(target, inst, e) for e in range(target.rows * target.cols)]
        if self.kind == "join":
            conn = self.owner._symbols[self.fields[1].lstrip("@")]
            j = int(conn.indices[i, int(self.fields[2])])
            base = _resolve(scene, self.fields[3])
            out = self._resolver.expand(base, j)
        else:
            union = _resolve(scene, self.fields[1])
            offsets = union.offsets
            m = int(np.searchsorted(offsets, i, side="right") - 1)
            member = union.members[m]
            out = self._resolver.expand(member._attributes[self.fields[2]],
                                        i - int(offsets[m]))
        return out + [None] * (self.width - len(out))

    def __repr__(self) -> str:
        return f"<ParamSlot {' '.join(self.fields)}>"


class _ParamResolver:
    """Finds the parameters of attributes met behind JOINs and UNIONs."""

    def __init__(self, scene: Scene, ir: str):
        self.scene = scene
        self.ir = ir
        self.cache: Dict[str, list] = {}

    def slots(self, attr: Attribute) -> List[ParamSlot]:
        path = "::".join("@" + n for n in attr.owner.path + [attr.name])
        if path not in self.cache:
            native = compiler._module()
            self.cache[path] = native.attribute_params(
                self.ir, DIFFERENTIATION_PIPELINE, [path + "__jac"],
                self.scene.name)[0]
        return [ParamSlot(f[0], f, attr.owner, self) for f in self.cache[path]]

    def expand(self, attr: Attribute, instance: int) -> list:
        if attr.kind in ("data", "constant"):
            if attr.kind == "data" and any(t is attr for t in
                                           self.scene.minimizeTargets):
                return [(attr, instance, e)
                        for e in range(attr.rows * attr.cols)]
            return []
        out = []
        for slot in self.slots(attr):
            out += slot.locations(instance)
        return out


class LocalDerivatives:
    """Per-instance value, gradient and Hessian of one energy with respect to
    its local parameters (see :meth:`Scene.energyDerivatives`)."""

    def __init__(self, energy, value, gradient, hessian, projected, params,
                 inner_map=None, inner_projected=None, dofs=None):
        self.energy = energy
        self._dofs = dofs
        self._projected = projected
        #: Energy of every instance, shape (N,); None if not computed.
        self.value = value
        #: Gradient of every instance, shape (N, n).
        self.gradient = gradient
        #: Hessian of every instance, shape (N, n, n); None if not computed.
        self.hessian = hessian
        #: The parameter groups, in order.
        self.params = params
        #: With ``config.separate_reduced_hessians`` and a reduced-space
        #: projection: the inner maps J, shape (N, m, n), and the projected
        #: inner Hessians P, shape (N, m, m); otherwise None.
        self.innerMap = inner_map
        self.projectedInnerHessian = inner_projected

    @property
    def projectedHessian(self) -> np.ndarray:
        """PSD-projected Hessians by the energy's projection method, shape
        (N, n, n) (formed as J^T P J from the factors if kept separate)."""
        if self._projected is None and self.innerMap is not None:
            J, P = self.innerMap, self.projectedInnerHessian
            return np.einsum("nki,nkl,nlj->nij", J, P, J)
        return self._projected

    def dofs(self) -> np.ndarray:
        """The global DoF of each local parameter of every instance, shape
        (N, n), -1 for UNION padding: the placement indices of paper A.3,
        computed by the generated ``@E__dofs`` kernel (counted from 1 there,
        0 for padding)."""
        return self._dofs()

    def locations(self, i: int):
        """(target attribute, target instance, entry) of each local parameter
        of energy instance ``i`` (entries column-major), None for the zero
        padding of UNION slots."""
        out = []
        for slot in self.params:
            out += slot.locations(i)
        return out


def _compressed_sizes(dofs: np.ndarray) -> np.ndarray:
    """Distinct DoFs >= 0 per row of a DoF map (the runtime's count)."""
    return compiler._module().compressed_sizes(
        np.ascontiguousarray(dofs, dtype=np.int64))


_projectors: Dict[Tuple[int, str], tuple] = {}


def _projector(k: int, method: str):
    """A kernel projecting k x k symmetric matrices by ``method``, compiled
    the first time this size is met (paper 7.2) and cached."""
    key = (k, method)
    if key not in _projectors:
        s = Scene(f"yasps_project_{k}_{method}")
        p = s.addMesh("m").addPrimitive("p", numInstances=1)
        h = p.addAttribute("h", rows=k, cols=k)
        p.addAttribute("proj", computed_attribute=h.project(method))
        library, _ = _compile(emit_scene(s), ["@m::@p::@proj"], s)
        _projectors[key] = (library, "@m::@p::@proj")
    return _projectors[key]


def _project_compressed(dofs: np.ndarray, hess: np.ndarray, method: str,
                        threads: int) -> np.ndarray:
    """Projected local Hessians, each projected as the k x k matrix it adds
    to the global system (repeated DoFs merged, padding dropped) and written
    back at the first parameter of each DoF."""
    native = compiler._module()
    count, n = dofs.shape
    out = np.zeros((count, n, n))
    hess = np.ascontiguousarray(hess)
    for k, instances, matrices in native.compress_local_hessians(dofs, hess):
        if k == 0:
            continue
        library, path = _projector(int(k), method)
        projected = np.empty(matrices.size)
        # Symmetric matrices: row- and column-major storage agree.
        given = {"out": projected,
                 "attr": np.ascontiguousarray(matrices).reshape(-1)}
        library.launch(path, len(instances),
                       [given[kind] for kind, _ in dict(library.kernels)[path]],
                       threads)
        native.expand_local_hessians(dofs, int(k), instances,
                                     projected.reshape(matrices.shape), out)
    return out


@dataclass
class DerivativeKernels:
    """Which kernels give an energy's local derivatives (the attributes
    that ``differentiation_pipeline()`` makes of it)."""
    base: str         #: the energy's scene-relative path
    ir: str           #: the scene's IR
    pipeline: str     #: the differentiation pipeline
    separate: bool    #: projected Hessians kept as factors (__ij, inner)
    #: the kernels whose values are returned: __grad, __hess unless only
    #: assembly needs them, and the projected Hessian or its factors
    evaluated: List[str]
    #: whether assembly compresses repeated DoFs before projecting (paper
    #: 7.2), which needs the unprojected Hessian as well
    compress: bool
    paths: List[str]  #: every kernel to compile (evaluated, __hess, __dofs)


def derivative_kernels(scene: Scene, energy: Attribute,
                       assembly_only: bool) -> DerivativeKernels:
    """The kernels of ``energy``'s local derivatives; ``assembly_only``
    leaves out what assembly does not need (values, unprojected
    Hessians)."""
    if not any(e is energy for e in scene.energies):
        raise SceneError(f"{energy.describe()} is not an energy of scene "
                         f"'{scene.name}' (addEnergy)")
    if not scene.minimizeTargets:
        raise SceneError(f"scene '{scene.name}' has no minimisation targets "
                         "(addMinimizeTarget)")
    base = "::".join("@" + n for n in energy.owner.path + [energy.name])
    ir = emit_scene(scene, locations=True)
    pipeline = differentiation_pipeline()
    separate = config.separate_reduced_hessians and bool(
        compiler._module().attribute_params(
            ir, pipeline, [base + "__hess_inner_proj"], scene.name)[0])
    projected = [base + "__ij", base + "__hess_inner_proj"] if separate \
        else [base + "__hess_proj"]
    evaluated = [base + "__grad"] + \
        ([] if assembly_only else [base + "__hess"]) + projected
    compress = assembly_only and not separate and config.compress_local_hessians
    paths = evaluated + ([base + "__hess"] if compress else []) \
        + [base + "__dofs"]
    return DerivativeKernels(base, ir, pipeline, separate, evaluated,
                             compress, paths)


def derivative_compile_error(energy: Attribute, message: str) -> Exception:
    """The error to raise for a failed compilation of derivative kernels:
    an energy that reads no minimisation target has none."""
    if "does not name an attribute" in message:
        return SceneError(f"{energy.describe()} depends on no minimisation "
                          "target")
    return compiler.IRError(message)


def energy_derivatives(scene: Scene, energy: Attribute, threads: int = None,
                       assembly_only: bool = False) -> LocalDerivatives:
    """Local gradients and Hessians of a registered energy, per instance.
    ``assembly_only`` computes only what assembly needs: the gradients and
    the projected Hessians (or their factors), not the values and the
    unprojected Hessians."""
    spec = derivative_kernels(scene, energy, assembly_only)
    base, ir, evaluated, compress, paths = (spec.base, spec.ir, spec.evaluated,
                                            spec.compress, spec.paths)
    owner = energy.owner
    native = compiler._module()
    try:
        library, _ = _compile(ir, paths, scene, spec.pipeline)
    except native.IRError as err:
        raise derivative_compile_error(energy, str(err)) from None
    resolver = _ParamResolver(scene, ir)
    params = [ParamSlot(f[0], f, owner, resolver)
              for f in library.params(paths[0])]
    count = owner.numInstances
    workers = config.num_threads if threads is None else threads

    def run(path: str) -> np.ndarray:
        arguments = dict(library.kernels)[path]
        rows, cols = library.shape(path)
        out = np.empty(count * rows * cols, dtype=np.float64)
        buffers = [_buffer(scene, kind, p, out) for kind, p in arguments]
        library.launch(path, count, buffers, workers)
        return from_column_major(out, rows, cols)

    def dofs() -> np.ndarray:
        # 1-based in the kernel, 0 for padding; exact integers in f64.
        return run(base + "__dofs")[:, :, 0].astype(np.int64) - 1

    indices = dofs
    if compress and library.projection(base + "__hess_proj") == "full":
        known = dofs()
        if (_compressed_sizes(known) < known.shape[1]).any():
            hess = run(base + "__hess")
            method = next(m for e, _, m in scene._energies if e is energy)
            return LocalDerivatives(
                energy, None, run(base + "__grad")[:, :, 0], None,
                _project_compressed(known, hess, method, workers), params,
                dofs=lambda: known)
        # Nothing to compress: the fused kernel projects; the indices are
        # kept rather than computed again.
        indices = lambda: known  # noqa: E731
    results = {path[len(base) + 2:]: run(path) for path in evaluated}
    value = None if assembly_only else compute(energy, threads).value[:, 0, 0]
    return LocalDerivatives(energy, value, results["grad"][:, :, 0],
                            results.get("hess"), results.get("hess_proj"),
                            params, results.get("ij"),
                            results.get("hess_inner_proj"), indices)
