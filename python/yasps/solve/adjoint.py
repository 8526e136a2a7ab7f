"""Adjoints of energy minimisation: how a minimiser moves when the scene's
constants move.

At a minimiser x* of E(x; theta) the free gradient vanishes, so for a loss
L(x*) the implicit function theorem gives

    H lambda = dL/dx      (H the exact Hessian on the free DoFs)
    dL/dtheta = -lambda^T d(grad_x E)/dtheta

The mixed derivatives d(grad_x E)/dtheta come from the compiler: the scene
is emitted with the constants theta written as variables and minimised
over after the targets (``kernel_ir(differentiated=...)``), so each
energy's generated ``__hess`` kernel (or its exact factors J^T H_inner J,
EXACT_PIPELINE) is the exact Hessian in (x, theta), through JOINs, UNIONs
and any parameterisation; its (x, x) block is the Hessian the adjoint
solves with and its (x, theta) block the mixed derivatives. Scenes that
differentiate no constant compile nothing more.

:func:`adjoint_terms` evaluates those per-instance Hessians with the
global index of each local variable; :class:`AdjointSystem` assembles them
(SciPy, exact, for the small and medium scenes this is meant for) and
gives the solve and the vector-Jacobian products; :func:`equilibrium_gradient`
is the static case end to end (yasps.diff re-exports it).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Dict, List, Mapping, Optional, Sequence

import numpy as np

from ..compiler import MissingAttributeError
from ..compiler.params import JoinParam, ReadParam
from ..compiler.pipelines import DIFFERENTIATION_PIPELINE
from ..compiler.specs import scene_params
from ..frontend import introspect
from ..frontend.attribute import STORED_KINDS, Attribute, owner_of
from ..frontend.errors import ArgumentError, ArgumentTypeError, SceneError
from ..frontend.scene import Scene
from ..frontend.values import from_column_major, to_column_major
from ..ir import kernel_ir, resolve, symbol_path
from ..runtime import Backend
from .assembly import DofLayout
from .minimize import fixed_dof_mask
from .params import ParamResolver, ParamSlot

#: Exact Hessians, never projected: the adjoint needs H itself. Where an
#: energy's parameters reach it through a linear map J (JOINs of affine
#: bodies, cages, UNIONs of them), the compiler keeps H = J^T H_inner J as
#: its factors when they are the smaller (hessian-factors=auto), as the
#: Newton system does: a contact pair of caged points has 96 parameters, a
#: dense exact Hessian past the kernels' size limit, and 12 inner ones.
EXACT_PIPELINE = (f"{DIFFERENTIATION_PIPELINE}{{hessian-factors=auto "
                  "linear-maps=false}")


class AdjointWarning(UserWarning):
    """The state an adjoint starts from is not a converged minimiser, so
    the gradient it gives is that of a point the solve did not reach."""


class Variables:
    """The variables of the adjoint: the targets' DoFs (as DofLayout lays
    them out), then every entry of each parameter, instance after
    instance, column-major within an instance."""

    def __init__(self, scene: Scene, parameters: Sequence[Attribute]):
        self.layout = DofLayout(list(scene.minimizeTargets))
        self.parameters = list(parameters)
        self.offset: Dict[int, int] = dict(self.layout.offset)
        size = self.layout.size
        for p in self.parameters:
            self.offset[id(p)] = size
            size += owner_of(p).numInstances * p.rows * p.cols
        self.size = size

    @property
    def num_dofs(self) -> int:
        return self.layout.size

    def contains(self, attr: Attribute) -> bool:
        return id(attr) in self.offset

    def split(self, vector: np.ndarray, attr: Attribute) -> np.ndarray:
        """``attr``'s part of a vector over the variables, shaped like its
        value, (N, rows, cols)."""
        start = self.offset[id(attr)]
        n = owner_of(attr).numInstances * attr.rows * attr.cols
        return from_column_major(vector[start:start + n].copy(), attr.rows,
                                 attr.cols)


@dataclass
class EnergyTerm:
    """One energy's exact local gradients (N, n) and Hessians (N, n, n) in
    its local variables (targets and parameters), and the variable of each
    local variable, ``index`` (N, n), -1 for UNION padding."""
    energy: Attribute
    index: np.ndarray
    gradient: np.ndarray
    hessian: np.ndarray


class _Indexer:
    """The variables of every local parameter, as (instances, width)
    tables of global indices (-1: padding or not a variable), built from
    the compiler's parameter groups with array operations: an attribute's
    table is that of each of its groups side by side; a read of a stored
    attribute is its own entries; a JOIN gathers the rows of its base's
    table; a UNION stacks its members' tables. Tables are kept per
    attribute, so a source read by many energies is indexed once."""

    def __init__(self, scene: Scene, resolver: ParamResolver,
                 variables: Variables):
        self.scene, self.resolver, self.variables = scene, resolver, variables
        self._tables: Dict[int, np.ndarray] = {}

    def stored(self, attr: Attribute, instances: np.ndarray) -> np.ndarray:
        size = attr.rows * attr.cols
        if not self.variables.contains(attr):
            return np.full((len(instances), 0), -1, dtype=np.int64)
        return self.variables.offset[id(attr)] + \
            np.asarray(instances, dtype=np.int64)[:, None] * size + \
            np.arange(size)[None, :]

    def attribute(self, attr: Attribute) -> np.ndarray:
        """The table of every instance of ``attr``'s owner."""
        key = id(attr)
        if key not in self._tables:
            count = owner_of(attr).numInstances
            if attr.kind in STORED_KINDS:
                table = self.stored(attr, np.arange(count))
            else:
                table = self.groups(self.resolver.slots(attr), count)
            self._tables[key] = table
        return self._tables[key]

    def groups(self, slots: Sequence[ParamSlot], count: int) -> np.ndarray:
        parts = [self.group(slot, count) for slot in slots]
        return np.concatenate(parts, axis=1) if parts else \
            np.zeros((count, 0), dtype=np.int64)

    def group(self, slot: ParamSlot, count: int) -> np.ndarray:
        param, scene = slot.param, self.scene
        if isinstance(param, ReadParam):
            target = resolve(scene, param.target)
            instances = np.arange(count) if target.owner is slot.owner \
                else np.zeros(count, dtype=np.int64)
            return self.stored(target, instances)
        out = np.full((count, slot.width), -1, dtype=np.int64)
        if isinstance(param, JoinParam):
            conn = introspect.symbols(slot.owner)[param.connectivity.lstrip("@")]
            table = self.attribute(resolve(scene, param.base))
            gathered = table[np.asarray(conn.indices[:, param.slot],
                                        dtype=np.int64)]
            out[:, :gathered.shape[1]] = gathered
            return out
        union = resolve(scene, param.union)
        offsets = union.offsets
        for m, member in enumerate(union.members):
            table = self.attribute(
                introspect.named_attributes(member)[param.attribute])
            start = int(offsets[m])
            out[start:start + len(table), :table.shape[1]] = table
        return out


def adjoint_terms(scene: Scene, variables: Variables, backend: Backend,
                  threads: Optional[int] = None) -> List[EnergyTerm]:
    """Every registered energy's exact local derivatives in the targets
    and ``variables.parameters``, at the scene's current values (the
    collision pairs it holds included), evaluated on ``backend``'s host."""
    host = backend.host
    ir = kernel_ir(scene, differentiated=variables.parameters)
    factored = scene_params(scene, ir, EXACT_PIPELINE).factored
    resolver = ParamResolver(scene, ir)
    indexer = _Indexer(scene, resolver, variables)
    terms = []
    for energy in scene.energies:
        owner = owner_of(energy)
        count = owner.numInstances
        if count == 0:
            continue  # no pairs of this kind now: nothing to compile
        base = symbol_path(energy)
        paths = [base + "__grad"] + (
            [base + "__ij", base + "__hess_inner"] if base in factored
            else [base + "__hess"])
        try:
            kernels = host.compile(ir, paths, scene.name, EXACT_PIPELINE)
        except MissingAttributeError:
            continue  # reads neither a target nor a parameter
        index = indexer.groups([ParamSlot(p, owner, resolver) for p in
                                kernels.params(paths[0])], count)

        def output(path: str) -> np.ndarray:
            kernel = kernels.kernel(path)
            return np.array(host.to_host(
                host.run(kernels, scene, path, count, threads),
                (count, kernel.rows, kernel.cols)))
        gradient = output(paths[0])[:, :, 0]
        if base in factored:
            J, inner = output(paths[1]), output(paths[2])
            hessian = np.einsum("nki,nkl,nlj->nij", J, inner, J)
        else:
            hessian = output(paths[1])
        terms.append(EnergyTerm(energy, index, gradient, hessian))
    return terms


#: The Hessians an adjoint may solve with: the exact one (the gradient's
#: own), or each instance's block PSD-projected (eigenvalues clamped at 0),
#: as projected Newton steps with, for measuring what that costs.
HESSIANS = ("exact", "projected")


def projected_blocks(hessian: np.ndarray, index: np.ndarray,
                     num_dofs: int) -> np.ndarray:
    """Each instance's Hessian block in its target DoFs (``index`` below
    ``num_dofs``), eigenvalues clamped at 0; the rest zero."""
    is_dof = (index >= 0) & (index < num_dofs)
    block = hessian * (is_dof[:, :, None] & is_dof[:, None, :])
    values, vectors = np.linalg.eigh(block)
    return (vectors * np.maximum(values, 0.0)[:, None, :]) @ \
        np.transpose(vectors, (0, 2, 1))


class AdjointSystem:
    """The Hessian of the targets' free DoFs (exact, or projected:
    HESSIANS) and the mixed derivatives in the parameters, assembled from
    :func:`adjoint_terms`."""

    def __init__(self, variables: Variables, terms: Sequence[EnergyTerm],
                 fixed: Optional[np.ndarray] = None, hessian: str = "exact"):
        from scipy import sparse

        if hessian not in HESSIANS:
            raise ArgumentError(f"the adjoint's hessian must be one of "
                                f"{', '.join(HESSIANS)}, got {hessian!r}")

        self.variables = variables
        self.terms = list(terms)
        nx = variables.num_dofs
        self.fixed = np.zeros(nx, dtype=bool) if fixed is None \
            else np.asarray(fixed, dtype=bool)
        rows, cols, values = [], [], []
        gradient = np.zeros(nx)
        for term in self.terms:
            i = term.index[:, :, None]
            j = term.index[:, None, :]
            both = (i >= 0) & (i < nx) & (j >= 0) & (j < nx)
            both = np.broadcast_to(both, term.hessian.shape)
            local = term.hessian if hessian == "exact" else \
                projected_blocks(term.hessian, term.index, nx)
            rows.append(np.broadcast_to(i, term.hessian.shape)[both])
            cols.append(np.broadcast_to(j, term.hessian.shape)[both])
            values.append(local[both])
            own = (term.index >= 0) & (term.index < nx)
            gradient += np.bincount(term.index[own], term.gradient[own],
                                    minlength=nx)
        self.gradient = gradient
        self.hessian = sparse.coo_matrix(
            (np.concatenate(values) if values else np.zeros(0),
             (np.concatenate(rows) if rows else np.zeros(0, dtype=np.int64),
              np.concatenate(cols) if cols else np.zeros(0, dtype=np.int64))),
            shape=(nx, nx)).tocsc()

    def free_gradient_norm(self) -> float:
        """The largest entry of the gradient on the free DoFs (0 at an exact
        minimiser)."""
        free = self.gradient[~self.fixed]
        return float(np.abs(free).max()) if free.size else 0.0

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """lambda with H_ff lambda_f = rhs_f and lambda = 0 on fixed DoFs,
        by a sparse direct solve. Raises SceneError where H_ff is singular
        (a free DoF no energy holds)."""
        from scipy.sparse.linalg import MatrixRankWarning, spsolve

        free = np.flatnonzero(~self.fixed)
        out = np.zeros(self.variables.num_dofs)
        if free.size == 0:
            return out
        block = self.hessian[free][:, free]
        with warnings.catch_warnings():
            warnings.simplefilter("error", MatrixRankWarning)
            try:
                solved = spsolve(block.tocsc(), rhs[free])
            except MatrixRankWarning:
                raise SceneError("the adjoint's Hessian is singular on the "
                                 "free DoFs: some free DoF is held by no "
                                 "energy (fix it)") from None
        out[free] = solved
        return out

    def mixed_vjp(self, lam: np.ndarray) -> np.ndarray:
        """lambda^T d(grad_x E)/dtheta over the parameters' entries (the
        variables after the DoFs, in their order)."""
        nx = self.variables.num_dofs
        out = np.zeros(self.variables.size - nx)
        for term in self.terms:
            i = term.index[:, :, None]
            j = term.index[:, None, :]
            mixed = np.broadcast_to((i >= 0) & (i < nx) & (j >= nx),
                                    term.hessian.shape)
            rows = np.broadcast_to(i, term.hessian.shape)[mixed]
            cols = np.broadcast_to(j, term.hessian.shape)[mixed]
            out += np.bincount(cols - nx, lam[rows] * term.hessian[mixed],
                               minlength=out.size)
        return out


def checked_parameters(scene: Scene, parameters: Sequence[Attribute],
                       what: str) -> List[Attribute]:
    """``parameters`` as a list, each a stored attribute of ``scene`` that
    is not a target, none twice."""
    out: List[Attribute] = []
    for p in parameters:
        if not isinstance(p, Attribute):
            raise ArgumentTypeError(f"{what}: a parameter must be an "
                                    f"Attribute, not {type(p).__name__}")
        if p.kind not in STORED_KINDS:
            raise ArgumentError(
                f"{what}: {p.describe()} is computed; differentiate with "
                "respect to the stored constants it is computed from")
        if owner_of(p).scene is not scene:
            raise ArgumentError(f"{what}: {p.describe()} is not of scene "
                                f"{scene.name!r}")
        if any(p is t for t in scene.minimizeTargets):
            raise ArgumentError(f"{what}: {p.describe()} is a minimisation "
                                "target, not a parameter")
        if any(p is q for q in out):
            raise ArgumentError(f"{what}: {p.describe()} is listed twice")
        out.append(p)
    return out


def loss_vector(variables: Variables, dloss: Mapping[Attribute, object],
                what: str) -> np.ndarray:
    """dL/dx over the DoFs from ``dloss`` (target -> array shaped like its
    value; targets left out contribute nothing)."""
    out = np.zeros(variables.num_dofs)
    targets = variables.layout.targets
    for attr, value in dloss.items():
        if not any(attr is t for t in targets):
            raise ArgumentError(f"{what}: dloss names {attr.describe()}, "
                                "which is not a minimisation target")
        start = variables.offset[id(attr)]
        n = owner_of(attr).numInstances
        flat = to_column_major(value, n, attr.rows, attr.cols,
                               f"{what}: dloss of {attr.describe()}")
        out[start:start + flat.size] += flat
    return out


class Gradients(dict):
    """dL/dtheta per parameter (keyed by the Attribute), each shaped like
    the parameter's value, (N, rows, cols)."""


def equilibrium_gradient(scene: Scene, dloss: Mapping[Attribute, object],
                         parameters: Sequence[Attribute], backend: Backend,
                         fixed=None, threads: Optional[int] = None,
                         tolerance: float = 1e-6,
                         hessian: str = "exact") -> Gradients:
    """The gradient of a loss L(x*) with respect to ``parameters`` at the
    minimiser x* the scene holds (after a converged solve), given
    dL/dx* as ``dloss`` (target -> array shaped like its value). ``fixed``
    is minimizeEnergy's (one mask or None per target): fixed DoFs do not
    move with the parameters. Warns (AdjointWarning) when the free
    gradient's largest entry exceeds ``tolerance``: the adjoint holds at a
    minimiser only. ``hessian``: HESSIANS ("projected" gives another,
    approximate gradient: for measuring what projecting costs)."""
    what = "equilibrium_gradient"
    if not scene.minimizeTargets:
        raise SceneError(f"{what}: scene {scene.name!r} has no "
                         "minimisation target")
    params = checked_parameters(scene, parameters, what)
    variables = Variables(scene, params)
    rhs = loss_vector(variables, dloss, what)
    mask = fixed_dof_mask(variables.layout, fixed)
    system = AdjointSystem(variables, adjoint_terms(scene, variables, backend,
                                                    threads), mask, hessian)
    residual = system.free_gradient_norm()
    if residual > tolerance:
        warnings.warn(f"{what}: the free gradient's largest entry is "
                      f"{residual:.3g} (above {tolerance:g}): the scene is "
                      "not at a converged minimiser, so this is the "
                      "gradient of a point the solve did not reach",
                      AdjointWarning, stacklevel=2)
    lam = system.solve(rhs)
    total = -system.mixed_vjp(lam)
    return Gradients({p: variables.split(np.concatenate(
        [np.zeros(variables.num_dofs), total]), p) for p in params})
