"""Local derivatives of an energy, per instance, from its generated
kernels (gradient, Hessian, projected Hessian or its factors, placement
indices): as host arrays for users (:func:`energy_derivatives`), and in the
backend's memory for assembly (:func:`assembly_inputs`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Dict, List, Optional, Set, Tuple, cast

import numpy as np

from .. import config
from ..compiler import MissingAttributeError
from ..compiler.pipelines import differentiation_pipeline
from ..compiler.specs import (DerivativeKernels, KernelRequest,
                              derivative_kernels, scene_params)
from ..frontend import introspect
from ..frontend.attribute import Attribute, owner_of
from ..frontend.errors import SceneError
from ..frontend.scene import Scene
from ..frontend.state import StateKey
from ..ir import kernel_ir, symbol_path
from ..runtime import (Backend, DenseInputs, FactoredInputs, LocalInputs,
                       SlotFactoredInputs, compute)
from .compression import (compressed_sizes, project_compressed,
                          projector_request)
from .params import ParamResolver, ParamSlot
from .slots import SlotInputs, SlotPlan, slot_plan

#: Jacobian tables evaluated during one assembly, by kernel path: each
#: source's table is computed once and read by every energy reaching it.
TableCache = Dict[str, np.ndarray]


class NoDerivativesError(SceneError):
    """An energy that reads no minimisation target has no derivatives
    (assembly leaves it out)."""


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


def _request(scene: Scene, energy: Attribute, assembly_only: bool,
             ir: Optional[str], with_tables: bool
             ) -> Tuple[DerivativeKernels, Optional[SlotPlan], KernelRequest]:
    """What the kernels of ``energy``'s local derivatives are and the
    compiler request for them: with ``with_tables`` (assembly on a backend
    that takes slot Jacobian tables), a factored energy's J comes from
    shared tables, and its inner gradient and the tables' kernels replace
    ``__grad`` and ``__ij``."""
    spec = derivative_kernels(scene, energy, assembly_only, ir)
    paths = list(spec.paths)
    plan = slot_plan(scene, energy, spec.ir, spec.pipeline) \
        if with_tables and spec.separate else None
    if plan is not None:
        unused = (spec.path("ij"), spec.path("grad"))
        paths = [p for p in paths if p not in unused] + \
            [spec.path("ijac")] + plan.kernel_paths
    return spec, plan, KernelRequest(spec.ir, tuple(paths), scene.name,
                                     spec.pipeline)


def _takes_tables(backend: Backend) -> bool:
    """Whether assembly on ``backend`` reads J from shared slot Jacobian
    tables (the derivatives then run on the host)."""
    return bool(backend.slot_factors and backend.derivatives is backend.host
                and config.slot_jacobians)


def assembly_requests(scene: Scene, backend: Backend) -> List[KernelRequest]:
    """The compiler requests that assembling ``scene`` on ``backend`` makes
    (one per energy with derivatives), for compiling them up front."""
    ir = kernel_ir(scene)
    return [_request(scene, energy, True, ir, _takes_tables(backend))[2]
            for energy in _differentiated(scene)]


def projector_requests(scene: Scene, backend: Backend) -> List[KernelRequest]:
    """The compiler requests of the k x k projection kernels that
    progressive projection and compression (:mod:`.compression`) can need
    on ``scene``: per energy projected from its exact local Hessians (not
    factored, on a backend that differentiates on the host), every size k
    up to its local Hessian's n in steps of the targets' common instance
    size (a merged or dropped parameter removes a whole instance's DoFs).
    Call after the energies' derivative kernels are compiled: n is read off
    them."""
    if backend.derivatives is not backend.host or not scene.minimizeTargets:
        return []
    # Asked again at every step's compile check: kept while the scene's
    # structure, the backend and the settings stay.
    key = (kernel_ir(scene), id(backend), config.snapshot())
    kept = scene.state.get(_PROJECTOR_REQUESTS)
    if kept is None or kept[0] != key:
        kept = scene.state.set(_PROJECTOR_REQUESTS, (
            key, _projector_requests_of(scene, backend)))
    return list(kept[1])


#: projector_requests' answer, with what it depends on.
_PROJECTOR_REQUESTS: StateKey[Tuple[tuple, List[KernelRequest]]] = \
    StateKey("the projections compiled ahead")


def _projector_requests_of(scene: Scene, backend: Backend
                           ) -> List[KernelRequest]:
    step = 0
    for target in scene.minimizeTargets:
        step = math.gcd(step, target.rows * target.cols)
    methods = {id(e): m for e, _, m in introspect.energy_records(scene)}
    precision = config.resolve_precision(scene.precision)
    sizes: Set[Tuple[int, str]] = set()
    for request, energy in zip(assembly_requests(scene, backend),
                               _differentiated(scene)):
        spec = derivative_kernels(scene, energy, True, request.ir)
        method = methods[id(energy)]
        if spec.separate or method == "none":
            continue
        kernels = backend.derivatives.compile(request.ir, request.paths,
                                              request.name, request.pipeline)
        n = kernels.kernel(spec.path("hess")).rows
        sizes.update((k, method) for k in range(step, n + 1, step))
    return [projector_request(k, method, precision)
            for k, method in sorted(sizes)]


def _differentiated(scene: Scene) -> List[Attribute]:
    """The scene's energies that depend on a minimisation target, in the
    order of :func:`assembly_requests`."""
    if not scene.minimizeTargets:
        return []
    ir = kernel_ir(scene)
    gradients = scene_params(scene, ir, differentiation_pipeline()).gradients
    return [e for e in scene.energies if gradients[symbol_path(e)]]


class _Outputs:
    """An energy's derivative kernels compiled for one backend, run on
    demand; ``reuse`` keeps each output's memory for the next call (the
    assembly inputs of a Newton loop)."""

    def __init__(self, scene: Scene, energy: Attribute, backend: Backend,
                 threads: Optional[int], assembly_only: bool, reuse: bool,
                 ir: Optional[str] = None,
                 tables: Optional[TableCache] = None):
        #: With ``tables`` (assembly on a backend that takes them): J from
        #: shared slot Jacobian tables instead of per-instance ``__ij``.
        self.spec, self.plan, request = _request(
            scene, energy, assembly_only, ir, tables is not None)
        self.scene, self.energy, self.backend = scene, energy, backend
        self.threads, self.reuse = threads, reuse
        self.count = owner_of(energy).numInstances
        self.tables = tables
        try:
            self.kernels = backend.compile(request.ir, request.paths,
                                           request.name, request.pipeline)
            if self.plan is not None:
                self.plan.check(self.shape("hess_inner_proj")[1],
                                self.shape("dofs")[1])
        except MissingAttributeError:
            raise NoDerivativesError(f"{energy.describe()} depends on no "
                                     "minimisation target") from None
        self._dofs: Optional[np.ndarray] = None

    def shape(self, role: str) -> Tuple[int, int, int]:
        kernel = self.kernels.kernel(self.spec.path(role))
        return self.count, kernel.rows, kernel.cols

    def run(self, role: str):
        path = self.spec.path(role)
        return self.backend.run(self.kernels, self.scene, path, self.count,
                                self.threads,
                                ("derivatives", path) if self.reuse else None)

    def host(self, role: str) -> np.ndarray:
        return np.array(self.backend.to_host(self.run(role), self.shape(role)))

    def dofs(self) -> np.ndarray:
        """The (count, n) DoF map, -1 for padding (computed once)."""
        if self._dofs is None:
            self._dofs = _zero_based(self.backend.to_host(
                self.run("dofs"), self.shape("dofs")))
        return self._dofs

    def needs_compression(self) -> bool:
        """Whether assembly must merge repeated DoFs of some instance
        before a full projection (paper 7.2)."""
        if not self.spec.compress or self.kernels.kernel(
                self.spec.path("hess_proj")).projection != "full":
            return False
        dofs = self.dofs()
        return bool((compressed_sizes(dofs) < dofs.shape[1]).any())

    def inputs(self) -> LocalInputs:
        """Gradients and projected Hessians (or their factors) as the fused
        kernels compute them."""
        if self.plan is not None:
            return self._slot_inputs()
        n = self.shape("grad")[1]
        gradient = self.run("grad")
        if self.spec.separate:
            m = self.shape("hess_inner_proj")[1]
            return FactoredInputs(self.backend, self.count, n, gradient,
                                  inner_map=self.run("ij"),
                                  inner_hessian=self.run("hess_inner_proj"),
                                  inner_size=m)
        return DenseInputs(self.backend, self.count, n, gradient,
                           self.run("hess_proj"))

    def _table(self, table) -> np.ndarray:
        """A Jacobian table (instances, rows, cols), row-major, from the
        assembly's cache or computed now."""
        if table.jacobian is None:
            return np.eye(table.entries)[None]
        # Only _slot_inputs asks, and a plan comes only with tables.
        assert self.tables is not None
        if table.jacobian not in self.tables:
            count = table.source.owner.numInstances
            kernel = self.kernels.kernel(table.jacobian)
            out = self.backend.run(self.kernels, self.scene, table.jacobian,
                                   count, self.threads)
            # The runtime's tables are f64 (an f32 scene's are widened).
            self.tables[table.jacobian] = np.ascontiguousarray(
                self.backend.to_host(out, (count, kernel.rows, kernel.cols)),
                dtype=np.float64)
        return self.tables[table.jacobian]

    def _slot_inputs(self) -> LocalInputs:
        """The inner gradients and P, with J in shared tables."""
        plan = self.plan
        assert plan is not None  # inputs() comes here only with a plan
        # No instances read no table: none is evaluated for them.
        tables = [self._table(t) for t in plan.tables] if self.count else []
        slots = SlotInputs(tables, plan.slots, plan.sources(self.count))
        return SlotFactoredInputs(self.backend, self.count, plan.num_params,
                                  self.run("ijac"),
                                  inner_hessian=self.run("hess_inner_proj"),
                                  inner_size=plan.inner_size,
                                  slot_factors=slots)


@dataclass(frozen=True)
class InstanceUpdate:
    """Local Hessians to add to some instances of an energy only:
    ``instances`` (k,) and ``hessians`` (k, n * n, row-major)."""
    instances: np.ndarray
    hessians: np.ndarray


class Contribution:
    """What assembly needs of one energy: its local gradients and Hessians
    in the memory of the backend that differentiated it, and its DoF map.
    Every instance's Hessian is PSD-projected unless :meth:`inputs` is told
    which DoFs need it (progressively projected Newton), which energies
    with plain local Hessians on the host allow (:attr:`selective`);
    factored energies and those differentiated on a GPU stay projected."""

    def __init__(self, outputs: _Outputs, compressed: bool):
        self._outputs, self._compressed = outputs, compressed
        self._projected: Optional[LocalInputs] = None
        self._exact: Optional[np.ndarray] = None
        self._grad = None
        self.dofs: Callable[[], np.ndarray] = outputs.dofs
        #: whether instances may enter with their exact Hessians
        self.selective = (outputs.plan is None and not outputs.spec.separate
                          and outputs.backend is outputs.backend.host)
        #: instances, and how many the last :meth:`inputs` projected
        self.count = outputs.count
        self.projected_count = outputs.count
        #: per instance, whether what the last :meth:`inputs` and
        #: :meth:`projection_update` gave since holds its projected Hessian
        #: (None: every instance's)
        self._projected_instances: Optional[np.ndarray] = None
        #: the energy's projection method (addEnergy's ``projection``)
        self._method = next(m for e, _, m in
                            introspect.energy_records(outputs.scene)
                            if e is outputs.energy)

    def projected(self) -> LocalInputs:
        """Every instance's Hessian projected (computed once)."""
        if self._projected is None:
            outputs = self._outputs
            if not self.selective:
                self._projected = outputs.inputs()
            else:
                count, n, _ = outputs.shape("hess")
                hessians = self._projected_rows(np.ones(count, dtype=bool)) \
                    if self._compressed else outputs.run("hess_proj")
                self._projected = DenseInputs(outputs.backend, count, n,
                                              self._gradient(), hessians)
        return self._projected

    def inputs(self, projected_dofs: Optional[np.ndarray] = None
               ) -> LocalInputs:
        """The inputs with the Hessians of the instances that read a True
        entry of ``projected_dofs`` (a boolean mask of the global DoFs)
        projected and the others exact; None: all projected."""
        self.projected_count = self.count
        self._projected_instances = None
        if projected_dofs is None or not self.selective:
            return self.projected()
        reads = self._reads(projected_dofs)
        if reads.all() and self.count:
            return self.projected()
        self._projected_instances = reads
        outputs = self._outputs
        count, n, _ = outputs.shape("hess")
        exact = self._exact_hessians().reshape(count, n * n)
        if reads.any():
            # A copy: the exact Hessians' buffer is the kernel's, reused.
            exact = exact.copy()
            exact[reads] = self._projected_of(reads)
        return DenseInputs(outputs.backend, count, n, self._gradient(), exact)

    def _gradient(self):
        """The local gradients (computed once)."""
        if self._grad is None:
            self._grad = self._outputs.run("grad")
        return self._grad

    def projection_update(self, projected_dofs: np.ndarray
                          ) -> Optional[InstanceUpdate]:
        """What turns this energy's contribution as last given (by
        :meth:`inputs` and the updates since) into that of
        ``inputs(projected_dofs)`` when added to it: for the instances that
        read a True entry and were not projected yet, their projected minus
        their exact Hessians (no gradient); None where that is nothing.
        Progressive projection's retries at one point only add instances
        (the threshold falls), so each instance is projected once there.
        The instances to project must include those projected already
        (:meth:`updatable_to` says)."""
        if not self.selective:
            return None
        assert self.updatable_to(projected_dofs), \
            "an instance projected already would have to be made exact again"
        reads = self._reads(projected_dofs)
        before = self._projected_instances
        assert before is not None  # updatable_to: an exact or partial one
        self._projected_instances = reads
        new = reads & ~before
        if not new.any() or self._method == "none":
            return None
        count, n, _ = self._outputs.shape("hess")
        exact = self._exact_hessians().reshape(count, n * n)
        rows = np.flatnonzero(new)
        return InstanceUpdate(rows.astype(np.int64),
                              self._projected_of(new) - exact[rows])

    def updatable_to(self, projected_dofs: np.ndarray) -> bool:
        """Whether :meth:`projection_update` can reach
        ``inputs(projected_dofs)`` from what was last given: every instance
        projected now reads a True entry (a non-selective energy: always,
        it stays projected)."""
        if not self.selective:
            return True
        before = self._projected_instances
        if before is None:
            return False
        if not before.any():
            return True
        return not (before & ~self._reads(projected_dofs)).any()

    def _reads(self, projected_dofs: np.ndarray) -> np.ndarray:
        """Per instance, whether it reads a True entry of
        ``projected_dofs`` (the instances to project); counted in
        ``projected_count``."""
        if not projected_dofs.any():
            # The exact assembly of a new point: nothing chosen yet.
            self.projected_count = 0
            return np.zeros(self.count, dtype=bool)
        dofs = self.dofs()
        reads = cast(np.ndarray, np.where(
            dofs >= 0, projected_dofs[np.maximum(dofs, 0)], False).any(axis=1))
        self.projected_count = int(reads.sum())
        return reads

    def _exact_hessians(self) -> np.ndarray:
        """The unprojected local Hessians (computed once)."""
        if self._exact is None:
            self._exact = self._outputs.run("hess")
        return self._exact

    def _projected_of(self, rows: np.ndarray) -> np.ndarray:
        """The projected Hessians of the instances ``rows``, one row of
        n * n entries each: where few are chosen and the energy's projection
        kernel has not run at this point, only those, each projected as the
        matrix it adds to the system (:meth:`_projected_rows`); otherwise
        the projection kernel's over all instances."""
        count, n, _ = self._outputs.shape("hess")
        if self._compressed or (self._projected is None and
                                rows.sum() <= ROWS_FRACTION * count):
            return self._projected_rows(rows)
        projected = self.projected()
        # selective: whole projected Hessians
        assert isinstance(projected, DenseInputs)
        return projected.hessian.reshape(count, n * n)[rows]

    def _projected_rows(self, rows: np.ndarray) -> np.ndarray:
        """The projections of only the instances ``rows``, each of its
        exact Hessian as the k x k matrix it adds to the system (repeated
        DoFs merged, fixed ones dropped; solve/compression.py): the
        eigenvalues of that matrix clamped, whatever space the energy's own
        projection kernel projects in."""
        outputs = self._outputs
        count, n, _ = outputs.shape("hess")
        threads = config.num_threads if outputs.threads is None \
            else outputs.threads
        hessians = self._exact_hessians().reshape(count, n, n)
        return project_compressed(
            outputs.dofs()[rows], hessians[rows], self._method, threads,
            config.resolve_precision(outputs.scene.precision)
        ).reshape(-1, n * n)


#: Progressive projection: where at most this fraction of an energy's
#: instances is chosen, only those are projected (from their exact
#: Hessians); above it, the energy's projection kernel runs over all. On
#: the bunny dropped on a cloth (bench/benchlib/stark_scenes.py) retries chose a few
#: dozen of 7,356 tets, whose whole projection kernel took 7 ms per retry.
ROWS_FRACTION = 0.25


def assembly_contribution(scene: Scene, energy: Attribute, backend: Backend,
                          threads: Optional[int] = None,
                          ir: Optional[str] = None,
                          tables: Optional[TableCache] = None
                          ) -> Contribution:
    """What assembly needs of a registered energy, computed by the backend
    that differentiates for ``backend`` (see :class:`Contribution`).
    ``ir``: the scene's ``kernel_ir``, if the caller has it; ``tables``:
    the Jacobian tables of this assembly, shared by its energies (factored
    energies then take J from them where ``backend`` assembles slot factors
    and ``config.slot_jacobians`` allows). Raises NoDerivativesError for an
    energy without derivatives."""
    where = backend.derivatives
    if not _takes_tables(backend):
        tables = None
    elif tables is None:
        tables = {}
    outputs = _Outputs(scene, energy, where, threads, True, True, ir, tables)
    if not outputs.needs_compression():
        return Contribution(outputs, False)
    if where.host is not where:
        # Compression runs on the host: the energy is differentiated there.
        outputs = _Outputs(scene, energy, where.host, threads, True, True,
                           ir)
        if not outputs.needs_compression():
            return Contribution(outputs, False)
    return Contribution(outputs, True)


def assembly_inputs(scene: Scene, energy: Attribute, backend: Backend,
                    threads: Optional[int] = None, ir: Optional[str] = None,
                    tables: Optional[TableCache] = None
                    ) -> Tuple[LocalInputs, Callable[[], np.ndarray]]:
    """The local gradients and projected Hessians (or their factors) of a
    registered energy and its DoF map (computed when first asked for), as
    :func:`assembly_contribution` computes them."""
    contribution = assembly_contribution(scene, energy, backend, threads, ir,
                                         tables)
    return contribution.projected(), contribution.dofs


def gradient_request(scene: Scene, energy: Attribute) -> KernelRequest:
    """The compiler request of :func:`local_gradients`: the energy's local
    gradient and placement indices only."""
    spec = derivative_kernels(scene, energy, True)
    return KernelRequest(spec.ir, (spec.path("grad"), spec.path("dofs")),
                         scene.name, spec.pipeline)


def local_gradients(scene: Scene, energy: Attribute, backend: Backend,
                    threads: Optional[int] = None
                    ) -> Tuple[np.ndarray, np.ndarray]:
    """A registered energy's local gradients (N, n) and their DoFs (N, n),
    -1 for padding, as host arrays: what a force needs, without the
    Hessians and values :func:`energy_derivatives` computes."""
    request = gradient_request(scene, energy)
    kernels = backend.compile(request.ir, request.paths, request.name,
                              request.pipeline)
    count = owner_of(energy).numInstances
    out = []
    for path in request.paths:
        kernel = kernels.kernel(path)
        shape = (count, kernel.rows, kernel.cols)
        out.append(np.array(backend.to_host(
            backend.run(kernels, scene, path, count, threads), shape)))
    gradient, dofs = out
    return gradient[:, :, 0], _zero_based(dofs)


def _zero_based(dofs: np.ndarray) -> np.ndarray:
    """The (count, n) DoF map from a ``__dofs`` kernel's (count, n, 1)
    output: 1-based there, 0 for padding (exact integers in f64); here
    0-based, -1 for padding."""
    return dofs[:, :, 0].astype(np.int64) - 1


def energy_derivatives(scene: Scene, energy: Attribute, backend: Backend,
                       threads: Optional[int] = None) -> LocalDerivatives:
    """Values, local gradients, Hessians and projected Hessians (or their
    factors) of a registered energy, per instance, as host arrays."""
    outputs = _Outputs(scene, energy, backend, threads, False, False)
    spec = outputs.spec
    resolver = ParamResolver(scene, spec.ir)
    params: List[ParamSlot] = [
        ParamSlot(p, owner_of(energy), resolver)
        for p in outputs.kernels.params(spec.path("grad"))]
    results = {path[len(spec.base) + 2:]: outputs.host(path[len(spec.base) + 2:])
               for path in spec.evaluated}
    value = compute(energy, backend, threads).value[:, 0, 0]
    hessian = results.get("hess")
    if spec.separate:
        # Linear parameterisations: the local Hessian is J^T H_inner J.
        J = results["ij"]
        hessian = np.einsum("nki,nkl,nlj->nij", J, results["hess_inner"], J)
    return LocalDerivatives(energy, value, results["grad"][:, :, 0],
                            hessian, results.get("hess_proj"),
                            params, results.get("ij"),
                            results.get("hess_inner_proj"), outputs.dofs)
