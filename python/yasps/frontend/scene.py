"""Scenes, meshes, primitive types, primitive unions and connectivities.

The structure of the paper's section 4 and appendix F (Table 4)::

    s = scene("scene0")
    bunny = s.addMesh("bunny")
    bunny.addPrimitive("vertices", numInstances=n)
    bunny.vertices.addAttribute("position", rows=3, cols=1)

Every method checks its arguments before it changes anything, so an error
leaves the scene as it was.
"""

from __future__ import annotations

import itertools

import keyword
import re
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union, cast

import numpy as np

from .. import config
from . import values as _values
from .values import MAX_MATRIX_ENTRIES, as_count
from .attribute import PROJECTION_METHODS, Attribute, owner_of
from .state import SceneState, StateKey
from .errors import (ArgumentError, LineageError, NameLookupError,
                     SceneError, ShapeError)
from .services import services

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def _check_name(name: Any, what: str) -> str:
    if not isinstance(name, str) or not _NAME.match(name) or keyword.iskeyword(name):
        raise SceneError(f"{what} name must be an identifier (letters, digits, "
                         f"'_', not starting with a digit), got {name!r}")
    return name


class Entity:
    """Common behaviour of scenes, meshes, primitives and primitive unions:
    named attributes, ``entity["name"]`` access and the lineage."""

    kind = "entity"

    def __init__(self, name: str, parent: Optional["Entity"]):
        self._name = name
        self._parent = parent
        # One namespace per entity, as in the IR's symbol table: attributes,
        # child entities and connectivities cannot share a name.
        self._symbols: Dict[str, Any] = {}
        self._attributes: Dict[str, Attribute] = {}

    # ------------------------------------------------------------- identity

    @property
    def name(self) -> str:
        return self._name

    @property
    def parent(self) -> Optional["Entity"]:
        return self._parent

    @property
    def scene(self) -> "Scene":
        entity: Entity = self
        while entity._parent is not None:
            entity = entity._parent
        return cast("Scene", entity)  # the root of every lineage is a scene

    @property
    def path(self) -> List[str]:
        """Names from below the scene down to this entity."""
        names: List[str] = []
        entity: Optional[Entity] = self
        while entity is not None and entity._parent is not None:
            names.append(entity._name)
            entity = entity._parent
        return names[::-1]

    @property
    def qualifiedName(self) -> str:
        return ".".join(self.path) if self._parent is not None else self._name

    def describe(self) -> str:
        return f"{self.kind} '{self.qualifiedName}'"

    def __repr__(self) -> str:
        return f"<yasps.{type(self).__name__} {self.qualifiedName}>"

    @property
    def numInstances(self) -> int:
        return 1

    @property
    def isDynamic(self) -> bool:
        return False

    # ----------------------------------------------------------- attributes

    @property
    def attributes(self) -> Dict[str, Attribute]:
        """The named attributes of this entity, in creation order."""
        return dict(self._attributes)

    def __getitem__(self, name: str) -> Attribute:
        try:
            return self._attributes[name]
        except KeyError:
            known = ", ".join(self._attributes) or "none"
            raise NameLookupError(f"{self.describe()} has no attribute {name!r} "
                                  f"(it has: {known})") from None

    def __contains__(self, name: str) -> bool:
        return name in self._attributes

    def _check_new_symbol(self, name: str, what: str) -> str:
        _check_name(name, what)
        if what in ("mesh", "primitive", "primitive union") and \
                hasattr(type(self), name):
            # Meshes and primitives are also reached as scene.<mesh> and
            # mesh.<primitive>, which the entity's own members would hide.
            raise SceneError(f"{what} name {name!r} is a member of "
                             f"{type(self).__name__} (scene.<mesh> and "
                             f"mesh.<primitive> would not reach it); choose "
                             f"another name")
        if name in self._symbols:
            raise SceneError(f"{self.describe()} already has "
                             f"{self._symbols[name]!r} named {name!r}")
        return name

    def _register(self, attr: Attribute) -> Attribute:
        name = attr.name
        assert name is not None  # every caller creates it with its name
        self._symbols[name] = attr
        self._attributes[name] = attr
        self._changed()
        return attr

    def _changed(self) -> None:
        """Marks the scene's structure (what its IR says) as changed: every
        method that adds to what the IR prints calls it, and caches of the
        emitted IR (``ir.kernel_ir``) are keyed by the count."""
        self.scene._structure += 1

    def addConstant(self, name: str, rows: int, cols: int = 1) -> Attribute:
        """Adds a stored attribute that is never differentiated."""
        return self._add_stored(name, rows, cols, "constant")

    def _add_stored(self, name: str, rows: Any, cols: Any, kind: str) -> Attribute:
        self._check_new_symbol(name, "attribute")
        for what, n in (("rows", rows), ("cols", cols)):
            if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
                raise ShapeError(f"attribute {name!r} on {self.describe()}: "
                                 f"{what} must be a positive integer, got {n!r}")
        if rows * cols > MAX_MATRIX_ENTRIES:
            raise ShapeError(f"attribute {name!r} on {self.describe()}: "
                             f"{rows}x{cols} has {rows * cols} entries; a "
                             f"matrix has at most {MAX_MATRIX_ENTRIES}")
        return self._register(Attribute(owner=self, rows=rows, cols=cols,
                                        kind=kind, name=name))

    def addAttribute(self, name: str, rows: Optional[int] = None,
                     cols: Optional[int] = None, *,
                     through: Optional["Connectivity"] = None,
                     source: Optional[Attribute] = None,
                     computed_attribute: Optional[Attribute] = None) -> Attribute:
        """Adds a named attribute and returns it.

        - ``addAttribute(name, rows=, cols=1)``: a stored, differentiable
          attribute (a possible minimisation target);
        - ``addAttribute(name, computed_attribute=expr)``: names an
          expression; it must belong to this entity (its deepest operand);
        - ``addAttribute(name, through=conn, source=attr)``: a JOIN (only on
          primitives);
        - ``addAttribute(name)`` on a primitive union: a UNION of the
          members' attributes of that name.
        """
        given = [k for k, v in (("rows", rows), ("through", through),
                                ("computed_attribute", computed_attribute))
                 if v is not None]
        if len(given) > 1 or (source is not None and through is None):
            raise SceneError(
                f"addAttribute({name!r}) on {self.describe()}: give rows/cols, "
                "computed_attribute=, or through= with source=, not a mix")
        if through is not None:
            return self._add_join(name, through, source)
        if computed_attribute is not None:
            return self._add_computed(name, computed_attribute)
        if rows is None:
            return self._add_without_shape(name)
        return self._add_stored(name, rows, 1 if cols is None else cols, "data")

    def _add_without_shape(self, name: str) -> Attribute:
        raise ShapeError(f"addAttribute({name!r}) on {self.describe()}: give "
                         "the shape (rows=, cols=) of a stored attribute")

    def _add_join(self, name: str, through: "Connectivity",
                  source: Optional[Attribute]) -> Attribute:
        raise LineageError(f"addAttribute({name!r}, through=...) on "
                           f"{self.describe()}: JOIN needs a primitive that "
                           "owns the connectivity")

    def _add_computed(self, name: str, expr: Attribute) -> Attribute:
        self._check_new_symbol(name, "attribute")
        if not isinstance(expr, Attribute):
            raise SceneError(f"addAttribute({name!r}): computed_attribute must "
                             f"be a yasps attribute, got {type(expr).__name__}")
        if expr.owner is not None and expr.owner is not self:
            lineage = []
            entity: Optional[Entity] = self
            while entity is not None:
                lineage.append(entity)
                entity = entity.parent
            if expr.owner in lineage:
                raise LineageError(
                    f"addAttribute({name!r}) on {self.describe()}: "
                    f"{expr.describe()} only reads attributes of "
                    f"{expr.owner.describe()}, so it belongs there; add it to "
                    f"{expr.owner.describe()} instead")
            raise LineageError(
                f"addAttribute({name!r}) on {self.describe()}: "
                f"{expr.describe()} is not on the lineage of {self.describe()}; "
                "use a JOIN or a UNION to bring it here")
        return self._register(Attribute(owner=self, rows=expr.rows,
                                        cols=expr.cols, kind="computed",
                                        op="computed", operands=(expr,),
                                        name=name))


#: The report of a scene's last minimizeEnergy (``Scene.lastSolve``).
LAST_SOLVE: StateKey[Dict[str, Any]] = StateKey("the last solve's report")


class Scene(Entity):
    """The global scope of a simulation: meshes, scene attributes, energies."""

    kind = "scene"

    def __init__(self, name: str, precision: Optional[str] = None):
        super().__init__(_check_name(name, "scene"), None)
        if precision is not None and precision not in config.PRECISIONS:
            raise ArgumentError(f"scene '{name}': precision must be one of "
                                f"{config.PRECISIONS}, got {precision!r}")
        #: The float type this scene's kernels compute in; None follows
        #: ``yasps.config.precision``.
        self.precision: Optional[str] = precision
        self._meshes: Dict[str, Mesh] = {}
        self._energies: List[tuple] = []  # (attribute, dynamic, projection)
        self._targets: List[Attribute] = []
        self._energy_counter = 0
        #: Counts the changes of what the scene's IR says (Entity._changed).
        self._structure = 0
        self._state = SceneState()

    @property
    def lastSolve(self) -> Dict[str, Any]:
        """The report of the last ``minimizeEnergy`` (see there); raises
        SceneError before the first."""
        report = self._state.get(LAST_SOLVE)
        if report is None:
            raise SceneError(f"scene '{self._name}' has solved nothing yet: "
                             "lastSolve is the report of minimizeEnergy")
        return report

    @property
    def state(self) -> SceneState:
        """What the layers above keep for this scene (frontend.state):
        kernel IR, plans, the Newton system, the preconditioner's choice."""
        return self._state

    @property
    def meshes(self) -> Dict[str, "Mesh"]:
        return dict(self._meshes)

    def __getattr__(self, name: str) -> "Mesh":
        meshes = self.__dict__.get("_meshes", {})
        if name in meshes:
            return meshes[name]
        raise AttributeError(f"scene '{self._name}' has no mesh {name!r}")

    def addMesh(self, name: str) -> "Mesh":
        """Adds a mesh and returns it (also reachable as ``scene.<name>``)."""
        self._check_new_symbol(name, "mesh")
        mesh = Mesh(name, self)
        self._symbols[name] = mesh
        self._changed()
        self._meshes[name] = mesh
        return mesh

    # ------------------------------------------------------------- energies

    @property
    def energies(self) -> List[Attribute]:
        return [energy[0] for energy in self._energies]

    @property
    def minimizeTargets(self) -> List[Attribute]:
        return list(self._targets)

    def addEnergy(self, attr: Attribute, dynamic_instances: bool = False,
                  projection: str = "clamp") -> Attribute:
        """Registers a 1x1 attribute as an energy term (summed over its
        instances). Energies on dynamic primitives (collision pairs) need
        ``dynamic_instances=True``. ``projection`` makes the local Hessians
        positive semi-definite: ``clamp`` (negative eigenvalues to zero, the
        default), ``abs`` or ``none``. An anonymous expression is named
        ``energy<k>`` on its owner. Returns the registered attribute."""
        if projection not in PROJECTION_METHODS:
            raise SceneError(f"addEnergy: projection must be one of "
                             f"{', '.join(PROJECTION_METHODS)}, got "
                             f"{projection!r}")
        if not isinstance(attr, Attribute):
            raise SceneError(f"addEnergy: expected a yasps attribute, got "
                             f"{type(attr).__name__}")
        if attr.shape != (1, 1):
            raise ShapeError(f"addEnergy: an energy must be 1x1 per instance, "
                             f"got {attr.describe()}")
        owner = attr.owner
        if owner is None or owner.scene is not self:
            raise SceneError(f"addEnergy: {attr.describe()} does not belong to "
                             f"scene '{self._name}'")
        if owner.isDynamic and not dynamic_instances:
            raise SceneError(
                f"addEnergy: {attr.describe()} lives on {owner.describe()}, "
                "whose instances change at run time; pass "
                "dynamic_instances=True")
        if dynamic_instances and not owner.isDynamic:
            raise SceneError(f"addEnergy: dynamic_instances=True but "
                             f"{owner.describe()} is not dynamic")
        if any(energy[0] is attr for energy in self._energies):
            raise SceneError(f"addEnergy: {attr.describe()} is already an energy")
        if not attr.isNamed:
            while f"energy{self._energy_counter}" in owner._symbols:
                self._energy_counter += 1
            attr = owner.addAttribute(f"energy{self._energy_counter}",
                                      computed_attribute=attr)
        self._energies.append((attr, bool(dynamic_instances), projection))
        self._changed()
        return attr

    def addMinimizeTarget(self, targets: Union[Attribute, Sequence[Attribute]]) -> None:
        """Declares the data attributes the energy is minimised over, in the
        order ``minimizeEnergy`` returns their solutions, and verifies the
        scene (raising :class:`~yasps.errors.IRError`). Further calls
        append. The energies are differentiated with the first compilation
        (``yasps.compile(scene)``, or the first ``minimizeEnergy``), which
        raises IRError for an energy that cannot be (differentiating here
        took seconds per call on contact scenes)."""
        if isinstance(targets, Attribute):
            targets = [targets]
        new: List[Attribute] = []
        for target in targets:
            if not isinstance(target, Attribute) or target.kind != "data":
                what = (target.describe() if isinstance(target, Attribute)
                        else type(target).__name__)
                raise SceneError(
                    f"addMinimizeTarget: {what} is not a data attribute; only "
                    "attributes added with addAttribute(name, rows=, cols=) "
                    "can be minimised")
            if owner_of(target).scene is not self:
                raise SceneError(f"addMinimizeTarget: {target.describe()} does "
                                 f"not belong to scene '{self._name}'")
            if any(t is target for t in self._targets + new):
                raise SceneError(f"addMinimizeTarget: {target.describe()} is "
                                 "listed twice")
            new.append(target)
        self._targets.extend(new)
        self._changed()
        try:
            services().verify(self)
        except Exception:
            self._targets = self._targets[:len(self._targets) - len(new)]
            self._changed()
            raise

    # ---------------------------------------------------------- evaluation

    def evaluateEnergy(self, threads: Optional[int] = None) -> float:
        """The total energy: every registered energy summed over its
        instances, evaluated with compiled kernels."""
        return services().total_energy(self, threads)

    def energyDerivatives(self, energy: Attribute,
                          threads: Optional[int] = None):
        """Per-instance value, local gradient and local Hessian of a
        registered energy with respect to its local parameters (entries of
        the minimisation targets it reads or gathers), for tests and
        debugging. Returns a :class:`yasps.solve.LocalDerivatives`."""
        return services().energy_derivatives(self, energy, threads)

    def minimizeEnergy(self, tolerance: float = 1e-6, maxIterations: int = 1000,
                       threads: Optional[int] = None,
                       fixed: Optional[list] = None,
                       stopping: str = "residual",
                       projectionThreshold: Optional[float] = None) -> list:
        """Assembles the gradient g and PSD-projected Hessian H of all
        energies and solves ``H dx = g`` with block-Jacobi PCG. Returns one
        ``(N, rows, cols)`` array per minimisation target, in the order
        given to ``addMinimizeTarget``; the Newton step is ``-dx`` (paper
        4.8). ``fixed`` excludes DoFs from the solve (their ``dx`` is 0):
        one entry per target, None or a boolean mask of its instances
        ``(N,)`` or entries ``(N, rows, cols)``.

        ``stopping="residual"`` (the default) stops once ``||g - H dx|| <=
        tolerance ||g||``, on the residual recomputed from ``dx``;
        ``"energy_norm"`` once the estimated energy-norm error
        ``||dx - dx*||_H`` is at most ``tolerance ||dx||_H``, which measures
        the step itself where stiff parts make the residual say little;
        ``"preconditioned"`` once ``r^T M^-1 r <= tolerance^2 g^T M^-1
        g`` with M the preconditioner, on the residual CG updates: the rule
        of GIPC and of the YASPS paper, which compare the squared ratio
        with their tolerance (their 1e-4 is a tolerance of 1e-2 here).

        ``lastSolve`` holds the iteration count, the recomputed residual,
        why PCG stopped, CG's condition estimate, the Hessian's diagonal
        ratio and the seconds spent on derivatives, indices, assembly and
        the solve (the paper's Fig. 20 breakdown). Raises
        :class:`yasps.SolverError` if PCG does not converge (naming the
        energy and instance of a NaN), :class:`yasps.SceneError` if no
        energy reads a target, and warns (``IllConditionedSolve``) when the
        residual bounds the step's error by more than 1.

        ``projectionThreshold`` (progressively projected Newton, SymX's and
        STARK's default): project only the local Hessians of the instances
        that read a DoF block (a target instance) whose gradient has an
        entry of this magnitude or more (fixed DoFs aside), and take the
        others exact; 0 projects all, ``inf`` none. The system may then be
        indefinite: PCG stops with "breakdown" where it meets negative
        curvature, and ``lastSolve`` tells ``descends`` (whether ``-dx``
        lowers the energy to first order), ``gradientMax`` (over the free
        DoFs) and ``projectedInstances`` of ``instances``. Energies with
        factored Hessians (reduced-space projection) and those
        differentiated on a GPU are always projected."""
        return services().minimize_energy(self, tolerance, maxIterations,
                                          threads, fixed, stopping,
                                          projectionThreshold)

    # ------------------------------------------------------------------ IR

    def ir(self, verify: bool = True, locations: bool = False) -> str:
        """The scene as yasps IR text.

        With ``verify`` (the default) the C++ dialect parses and verifies it
        first (raising :class:`~yasps.errors.IRError`); ``locations`` adds
        the Python file and line that created each attribute.
        """
        if verify:
            self.verify()
        return services().emit(self, locations)

    def verify(self) -> None:
        """Has the C++ compiler parse and verify the scene's IR."""
        services().verify(self)


class Mesh(Entity):
    """A group of primitive types and primitive unions."""

    kind = "mesh"

    def __init__(self, name: str, parent: Scene):
        super().__init__(name, parent)
        self._children: Dict[str, Union[Primitive, PrimitiveUnion]] = {}

    @property
    def primitives(self) -> Dict[str, Union["Primitive", "PrimitiveUnion"]]:
        """Primitive types and unions of the mesh, in creation order."""
        return dict(self._children)

    def __getattr__(self, name: str) -> Union["Primitive", "PrimitiveUnion"]:
        children = self.__dict__.get("_children", {})
        if name in children:
            return children[name]
        raise AttributeError(f"mesh '{self._name}' has no primitive {name!r}")

    def addPrimitive(self, name: str, numInstances: int = 0,
                     isDynamic: bool = False) -> "Primitive":
        """Adds a primitive type with ``numInstances`` instances. A dynamic
        primitive (collision pairs) may change its count at run time."""
        self._check_new_symbol(name, "primitive")
        count = as_count(numInstances, f"addPrimitive({name!r}): numInstances")
        primitive = Primitive(name, self, count, bool(isDynamic))
        self._symbols[name] = primitive
        self._changed()
        self._children[name] = primitive
        return primitive

    def addPrimitiveUnion(self, name: str,
                          members: Sequence[Union["Primitive", "PrimitiveUnion"]]
                          ) -> "PrimitiveUnion":
        """Adds a primitive type whose instances are those of ``members``
        (primitives or unions, possibly of other meshes), member after
        member."""
        self._check_new_symbol(name, "primitive union")
        members = list(members)
        if not members:
            raise SceneError(f"addPrimitiveUnion({name!r}): needs at least one "
                             "member")
        for member in members:
            if not isinstance(member, (Primitive, PrimitiveUnion)):
                raise SceneError(
                    f"addPrimitiveUnion({name!r}): members must be primitives "
                    f"or primitive unions, got {member!r}")
            if member.scene is not self.scene:
                raise SceneError(f"addPrimitiveUnion({name!r}): "
                                 f"{member.describe()} is in another scene")
        if len({id(m) for m in members}) != len(members):
            raise SceneError(f"addPrimitiveUnion({name!r}): a member is "
                             "listed twice")
        union = PrimitiveUnion(name, self, members)
        self._symbols[name] = union
        self._changed()
        self._children[name] = union
        return union


class Primitive(Entity):
    """A primitive type: a collection of instances with attributes and
    connectivities."""

    kind = "primitive"

    def __init__(self, name: str, parent: Mesh, numInstances: int,
                 isDynamic: bool):
        super().__init__(name, parent)
        self._count = numInstances
        self._dynamic = isDynamic
        self._connectivities: Dict[str, Connectivity] = {}

    @property
    def numInstances(self) -> int:
        return self._count

    @property
    def isDynamic(self) -> bool:
        return self._dynamic

    @property
    def connectivities(self) -> Dict[str, "Connectivity"]:
        return dict(self._connectivities)

    def updateNumInstances(self, n: int) -> None:
        """Changes the instance count of a dynamic primitive. The values of
        its stored attributes and its connectivities must then be given again
        (``updateValue``, ``updateConnectivity``)."""
        if not self._dynamic:
            raise SceneError(f"updateNumInstances: {self.describe()} is not "
                             "dynamic (create it with isDynamic=True)")
        self._count = as_count(n, f"updateNumInstances of {self.describe()}")
        for attr in self._attributes.values():
            attr._invalidate_values()
        for conn in self._connectivities.values():
            conn._indices = None

    def addConnectivity(self, name: str,
                        target: Union["Primitive", "PrimitiveUnion"],
                        indices: Any, arity: int) -> "Connectivity":
        """Adds a connectivity of ``arity`` from this primitive to ``target``:
        ``indices`` has shape (numInstances, arity) or is flat; for a union
        target the indices are union indices (see
        :meth:`PrimitiveUnion.indexOf`)."""
        self._check_new_symbol(name, "connectivity")
        if not isinstance(target, (Primitive, PrimitiveUnion)):
            raise SceneError(f"addConnectivity({name!r}): the target must be a "
                             f"primitive or primitive union, got {target!r}")
        if target.scene is not self.scene:
            raise SceneError(f"addConnectivity({name!r}): {target.describe()} "
                             "is in another scene")
        if not isinstance(arity, (int, np.integer)) or isinstance(arity, bool) or arity < 1:
            raise SceneError(f"addConnectivity({name!r}): arity must be a "
                             f"positive integer, got {arity!r}")
        conn = Connectivity(name, self, target, int(arity))
        conn._indices = conn._validate(indices)
        self._symbols[name] = conn
        self._changed()
        self._connectivities[name] = conn
        return conn

    def _add_without_shape(self, name: str) -> Attribute:
        raise ShapeError(f"addAttribute({name!r}) on {self.describe()}: give "
                         "rows= and cols= for a stored attribute, "
                         "computed_attribute= or through=/source=")

    def _add_join(self, name: str, through: "Connectivity",
                  source: Optional[Attribute]) -> Attribute:
        self._check_new_symbol(name, "attribute")
        if not isinstance(through, Connectivity) or through.source is not self:
            raise LineageError(
                f"addAttribute({name!r}, through=...) on {self.describe()}: "
                f"{through!r} is not a connectivity of {self.describe()}")
        if not isinstance(source, Attribute):
            raise SceneError(f"addAttribute({name!r}, through=...): source= "
                             "must be an attribute")
        if not source.isNamed:
            raise LineageError(
                f"addAttribute({name!r}, through=...): the JOIN source "
                f"{source.describe()} is an unnamed expression; name it on "
                f"{through.target.describe()} with addAttribute(name, "
                "computed_attribute=...) first")
        if source.owner is not through.target:
            raise LineageError(
                f"addAttribute({name!r}, through={through.name}): the source "
                f"{source.describe()} is not an attribute of the "
                f"connectivity's target {through.target.describe()}")
        attr = Attribute(owner=self, rows=through.arity,
                         cols=source.rows * source.cols, kind="join",
                         op="join", operands=(source,), name=name,
                         params={"connectivity": through})
        return self._register(attr)


class PrimitiveUnion(Entity):
    """A primitive type made of the instances of other primitives or unions."""

    kind = "primitive union"

    def __init__(self, name: str, parent: Mesh,
                 members: List[Union[Primitive, "PrimitiveUnion"]]):
        super().__init__(name, parent)
        self._members = members

    @property
    def members(self) -> List[Union[Primitive, "PrimitiveUnion"]]:
        return list(self._members)

    @property
    def numInstances(self) -> int:
        return sum(m.numInstances for m in self._members)

    @property
    def isDynamic(self) -> bool:
        return any(m.isDynamic for m in self._members)

    @property
    def offsets(self) -> np.ndarray:
        """Prefix offsets: member j's instances are numbered from
        ``offsets[j]`` to ``offsets[j+1]-1``."""
        return np.concatenate([[0], np.cumsum([m.numInstances for m in self._members])]).astype(np.int64)

    def indexOf(self, member: Union[Primitive, "PrimitiveUnion"],
                instances: Any) -> Any:
        """Union indices of the given instances of ``member`` (an int or an
        integer array), for connectivities that target this union."""
        for j, m in enumerate(self._members):
            if m is member:
                break
        else:
            raise SceneError(f"indexOf: {member!r} is not a member of "
                             f"{self.describe()}")
        array = np.asarray(instances)
        if not np.issubdtype(array.dtype, np.integer):
            raise SceneError(f"indexOf: instance indices must be integers, got "
                             f"dtype {array.dtype}")
        if array.size and (array.min() < 0 or array.max() >= member.numInstances):
            raise SceneError(f"indexOf: instance index out of range for "
                             f"{member.describe()} with {member.numInstances} "
                             "instances")
        result = array + self.offsets[j]
        return int(result) if np.ndim(instances) == 0 else result

    def _add_without_shape(self, name: str) -> Attribute:
        # UNION of the members' attributes called `name`.
        self._check_new_symbol(name, "attribute")
        found: List[Tuple[Union[Primitive, PrimitiveUnion], Attribute]] = []
        missing: List[Tuple[Union[Primitive, PrimitiveUnion], None]] = []
        for member in self._members:
            attr = member._attributes.get(name)
            if attr is not None:
                found.append((member, attr))
            else:
                missing.append((member, attr))
        if missing:
            raise LineageError(
                f"addAttribute({name!r}) on {self.describe()}: UNION needs "
                f"attribute {name!r} on every member, but "
                + ", ".join(m.describe() for m, _ in missing) + " lack(s) it")
        shapes = {attr.shape for _, attr in found}
        if len(shapes) != 1:
            raise ShapeError(
                f"addAttribute({name!r}) on {self.describe()}: UNION needs one "
                "shape, got " + ", ".join(a.describe() for _, a in found))
        rows, cols = found[0][1].shape
        return self._register(Attribute(
            owner=self, rows=rows, cols=cols, kind="union", op="union",
            operands=tuple(a for _, a in found), name=name))


_connectivity_versions = itertools.count(1)


class Connectivity:
    """A map from each instance of ``source`` to ``arity`` instances of
    ``target`` (paper section 4.4)."""

    def __init__(self, name: str, source: Primitive,
                 target: Union[Primitive, PrimitiveUnion], arity: int):
        self.name = name
        self.source = source
        self.target = target
        self.arity = arity
        self._indices: Optional[np.ndarray] = None
        # Changes with every updateConnectivity, so that structures derived
        # from the indices (the static part of the Newton system) notice.
        self._version = 0

    def __repr__(self) -> str:
        return (f"<yasps.Connectivity {self.name}: {self.source.qualifiedName}"
                f" -> {self.target.qualifiedName}, arity {self.arity}>")

    def describe(self) -> str:
        return f"connectivity '{self.source.qualifiedName}.{self.name}'"

    def _validate(self, indices: Any) -> np.ndarray:
        return _values.to_indices(indices, self.source.numInstances, self.arity,
                                  self.target.numInstances, self.describe())

    @property
    def indices(self) -> np.ndarray:
        """The indices as an (N, arity) int32 array."""
        if self._indices is None:
            raise SceneError(f"{self.describe()} has no indices for the "
                             f"current {self.source.numInstances} instances; "
                             "call updateConnectivity")
        return self._indices.reshape(-1, self.arity).copy()

    def updateConnectivity(self, indices: Any) -> None:
        """Replaces the indices (for a dynamic source, after
        ``updateNumInstances``); the count must match the source's."""
        self._indices = self._validate(indices)
        self._version = next(_connectivity_versions)


def scene(name: str, precision: Optional[str] = None) -> Scene:
    """Creates an empty scene (the paper's ``scene(sid)``). ``precision``
    ("f64" or "f32") is the float type its kernels compute in; None follows
    ``yasps.config.precision``."""
    return Scene(name, precision)
