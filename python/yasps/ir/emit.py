"""Printing a scene as yasps IR text (see docs/dialect.md).

Named attributes become declaration ops on their entity; every named
computed, JOIN or UNION attribute gets a region holding its expression, with
anonymous sub-expressions inlined and shared sub-expressions emitted once.
"""

from __future__ import annotations

from typing import Dict, List, Optional, Sequence, Set, Tuple

import numpy as np

from ..frontend.state import StateKey
from .. import config
from ..frontend import introspect
from ..frontend.attribute import Attribute
from ..frontend.scene import (Connectivity, Entity, Mesh, Primitive,
                              PrimitiveUnion, Scene)
from .symbols import entity_path, symbol_path
from ..frontend.errors import ArgumentError

_INDENT = "  "

# Ops printed as `yasps.<op> %a : T` and `yasps.<op> %a, %b : T`.
_UNARY_SAME = {"neg", "sqrt", "log", "exp", "sin", "cos", "abs",
               "stop_gradient", "inverse", "cofactor"}
_BINARY_SAME = {"add", "sub", "elementwise_mul", "atan2", "min", "max", "cross"}
_TO_SCALAR = {"det", "trace", "norm", "squared_norm", "sum",
              "singular_value_sum"}


# The largest finite f32: a literal beyond it does not exist in an f32 scene.
_F32_MAX = float(np.finfo(np.float32).max)


def mat_type(attr: Attribute, element: str = "f64") -> str:
    return f"!yasps.mat<{attr.rows}x{attr.cols}x{element}>"


def _float(value: float) -> str:
    text = repr(float(value))
    # MLIR float literals need a decimal point ("1e-10" would not parse).
    return text if "." in text else f"{value:.17e}"


def dense_literal(array: np.ndarray, element: str = "f64") -> str:
    rows, cols = array.shape
    if element == "f32":
        finite = array[np.isfinite(array)]
        if finite.size and np.abs(finite).max() > _F32_MAX:
            raise ArgumentError(
                f"the constant {np.abs(finite).max():g} is beyond the f32 "
                f"range (|x| <= {_F32_MAX:g}): compute this scene in f64")
    if np.all(array == array.flat[0]):
        body = _float(array.flat[0])
    else:
        body = "[" + ", ".join(
            "[" + ", ".join(_float(v) for v in row) + "]" for row in array) + "]"
    return f"dense<{body}> : tensor<{rows}x{cols}x{element}>"


class _Locations:
    """Source locations of the ops printed, as MLIR location aliases:
    each op refers to ``#locN`` (numbered in the order printed, which
    depends only on the scene's structure) and the aliases are defined
    after the scene, so the text above the definitions names what is
    compiled and nothing of where the script that built it stands.
    Without locations nothing is printed."""

    def __init__(self, enabled: bool):
        self.enabled = enabled
        self.definitions: List[str] = []

    def of(self, attr: Attribute) -> str:
        """`` loc(#locN)`` for ``attr``'s source location, or ""."""
        location = introspect.user_location(attr)
        if not self.enabled or location is None:
            return ""
        filename, line = location
        escaped = filename.replace("\\", "\\\\").replace('"', '\\"')
        alias = f"#loc{len(self.definitions)}"
        self.definitions.append(f'{alias} = loc("{escaped}":{line}:0)')
        return f" loc({alias})"

    def table(self) -> str:
        """The alias definitions (MLIR resolves them at the end of the
        file)."""
        return "".join(line + "\n" for line in self.definitions)


class _RegionPrinter:
    """Prints one computed attribute's region, numbering SSA values."""

    def __init__(self, locations: _Locations, element: str):
        self.locations = locations
        self.element = element
        self.names: Dict[int, str] = {}
        self.lines: List[str] = []

    def value(self, root: Attribute) -> str:
        # Iterative post-order: expressions can be deeper than Python's
        # recursion limit.
        stack: List[Tuple[Attribute, bool]] = [(root, False)]
        while stack:
            node, expanded = stack.pop()
            if id(node) in self.names:
                continue
            leaf = node.isNamed or node.kind == "literal"
            if leaf or expanded:
                self.names[id(node)] = self._emit(node)
                continue
            stack.append((node, True))
            for operand in reversed(introspect.operands(node)):
                if id(operand) not in self.names:
                    stack.append((operand, False))
        return self.names[id(root)]

    def _emit(self, node: Attribute) -> str:
        name = f"%{len(self.names)}"
        self.lines.append(f"{name} = {self._op_text(node)}"
                          f"{self.locations.of(node)}")
        return name

    def _op_text(self, node: Attribute) -> str:
        t = mat_type(node, self.element)
        if node.isNamed:
            return f"yasps.read {symbol_path(node)} : {t}"
        if node.kind == "literal":
            return (f"yasps.constant "
                    f"{dense_literal(introspect.parameters(node)['value'], self.element)}")
        op, p = introspect.operation(node), introspect.parameters(node)
        operands = introspect.operands(node)
        ops = [self.names[id(o)] for o in operands]
        types = [mat_type(o, self.element) for o in operands]
        if op in _UNARY_SAME:
            return f"yasps.{op} {ops[0]} : {t}"
        if op in _BINARY_SAME:
            return f"yasps.{op} {ops[0]}, {ops[1]} : {t}"
        if op in _TO_SCALAR:
            return f"yasps.{op} {ops[0]} : {types[0]}"
        if op == "dot":
            return f"yasps.dot {ops[0]}, {ops[1]} : {types[0]}"
        if op in ("scale", "div", "pow"):
            return f"yasps.{op} {ops[0]}, {ops[1]} : {types[0]}, {types[1]}"
        if op == "matmul":
            return (f"yasps.matmul {ops[0]}, {ops[1]} : {types[0]}, {types[1]}"
                    f" -> {t}")
        if op in ("transpose", "resize"):
            return f"yasps.{op} {ops[0]} : {types[0]} -> {t}"
        if op in ("row", "col"):
            return f"yasps.{op} {ops[0]}[{p['index']}] : {types[0]} -> {t}"
        if op == "element":
            return f"yasps.element {ops[0]}[{p['row']}, {p['col']}] : {types[0]}"
        if op == "slice":
            return (f"yasps.slice {ops[0]}[{p['row_offset']}, {p['col_offset']}]"
                    f" : {types[0]} -> {t}")
        if op == "cmp":
            return f"yasps.cmp {p['predicate']}, {ops[0]}, {ops[1]} : {t}"
        if op == "select":
            return f"yasps.select {ops[0]}, {ops[1]}, {ops[2]} : {types[0]}, {t}"
        if op == "project":
            return f"yasps.project {p['method']} {ops[0]} : {t}"
        if op == "concat":
            return (f"yasps.concat {p['axis']} {', '.join(ops)} : "
                    f"{', '.join(types)} -> {t}")
        raise AssertionError(f"no IR spelling for op {op!r}")


def _emit_attribute(attr: Attribute, depth: int, locations: _Locations,
                    element: str, variables: Set[int]) -> List[str]:
    pad = _INDENT * depth
    t = mat_type(attr, element)
    loc = locations.of(attr)
    decl = {"data": "yasps.data_attr", "constant": "yasps.const_attr"}
    if attr.kind in decl:
        # A constant differentiated against is a variable of the IR.
        kind = "data" if id(attr) in variables else attr.kind
        return [f"{pad}{decl[kind]} @{attr.name} : {t}{loc}"]
    region = _RegionPrinter(locations, element)
    if attr.kind == "join":
        conn: Connectivity = introspect.parameters(attr)["connectivity"]
        source = introspect.operands(attr)[0]
        result = "%0"
        region.lines.append(f"%0 = yasps.join @{conn.name}({symbol_path(source)})"
                            f" : {t}{loc}")
    elif attr.kind == "union":
        result = "%0"
        region.lines.append(f"%0 = yasps.union @{attr.name} : {t}{loc}")
    else:
        result = region.value(introspect.operands(attr)[0])
    body = [f"{pad}{_INDENT}{line}" for line in region.lines]
    return ([f"{pad}yasps.attr @{attr.name} : {t} {{"] + body +
            [f"{pad}{_INDENT}yasps.yield {result} : {t}", f"{pad}}}{loc}"])


def _emit_members(entity: Entity, depth: int, locations: _Locations,
                  extra: Dict[Entity, List[Tuple[str, Attribute]]],
                  dynamic_counts: bool, element: str,
                  variables: Set[int]) -> List[str]:
    lines: List[str] = []
    pad = _INDENT * depth
    symbols = list(introspect.symbols(entity).values())
    for name, expr in extra.get(entity, []):
        symbols.append(Attribute(owner=entity, rows=expr.rows, cols=expr.cols,
                                 kind="computed", op="computed",
                                 operands=(expr,), name=name))
    for symbol in symbols:
        if isinstance(symbol, Attribute):
            lines += _emit_attribute(symbol, depth, locations, element,
                                     variables)
        elif isinstance(symbol, Connectivity):
            lines.append(f"{pad}yasps.connectivity @{symbol.name} -> "
                         f"{entity_path(symbol.target)} arity {symbol.arity}")
        elif isinstance(symbol, Mesh):
            lines.append(f"{pad}yasps.mesh @{symbol.name} {{")
            lines += _emit_members(symbol, depth + 1, locations, extra,
                                   dynamic_counts, element, variables)
            lines.append(f"{pad}}}")
        elif isinstance(symbol, Primitive):
            dynamic = " dynamic" if symbol.isDynamic else ""
            count = symbol.numInstances
            if symbol.isDynamic and not dynamic_counts:
                count = 0
            lines.append(f"{pad}yasps.primitive @{symbol.name}"
                         f"({count}){dynamic} {{")
            lines += _emit_members(symbol, depth + 1, locations, extra,
                                   dynamic_counts, element, variables)
            lines.append(f"{pad}}}")
        elif isinstance(symbol, PrimitiveUnion):
            members = ", ".join(entity_path(m) for m in symbol.members)
            lines.append(f"{pad}yasps.primitive_union @{symbol.name} "
                         f"[{members}] {{")
            lines += _emit_members(symbol, depth + 1, locations, extra,
                                   dynamic_counts, element, variables)
            lines.append(f"{pad}}}")
    return lines


class KernelIR(str):
    """A scene's IR as kernels are compiled from it. The text itself is
    what caches are keyed by: ops refer to their source locations by
    aliases (``loc(#locN)``) whose definitions, ``locations``, are kept
    apart, so inserting lines above the scene code, renaming the script or
    running it under a profiler changes no key, while diagnostics still
    name the user's file and line. The compiler parses the text followed by
    ``locations`` (``text_and_locations``)."""

    locations: str

    def __new__(cls, text: str, locations: str = "") -> "KernelIR":
        ir = super().__new__(cls, text)
        ir.locations = locations
        return ir


def text_and_locations(ir: str) -> Tuple[str, str]:
    """``ir`` as the compiler takes it: the text that keys its caches and
    the location definitions parsed after it ("" for plain IR text)."""
    if isinstance(ir, KernelIR):
        return str(ir), ir.locations
    return str(ir), ""


def _emit(scene: Scene, locations: _Locations,
          extra: Optional[Dict[Entity, List[Tuple[str, Attribute]]]],
          dynamic_counts: bool, precision: Optional[str],
          differentiated: Sequence[Attribute] = ()) -> str:
    element = config.resolve_precision(
        precision if precision is not None else scene.precision)
    variables = {id(a) for a in differentiated}
    lines = [f"yasps.scene @{scene.name} {{"]
    lines += _emit_members(scene, 1, locations, extra or {}, dynamic_counts,
                           element, variables)
    for attr, dynamic, projection in introspect.energy_records(scene):
        flag = " dynamic_instances" if dynamic else ""
        if projection != "clamp":
            flag += f" projection {projection}"
        lines.append(f"{_INDENT}yasps.energy {symbol_path(attr)}{flag}")
    minimized = list(scene.minimizeTargets) + list(differentiated)
    if minimized:
        targets = ", ".join(symbol_path(t) for t in minimized)
        lines.append(f"{_INDENT}yasps.minimize [{targets}]")
    lines.append("}")
    return "\n".join(lines) + "\n"


def emit_scene(scene: Scene, locations: bool = False,
               extra: Optional[Dict[Entity, List[Tuple[str, Attribute]]]] = None,
               dynamic_counts: bool = True,
               precision: Optional[str] = None) -> str:
    """The scene as IR text (one `yasps.scene` op). ``locations`` adds
    the Python file and line that created each attribute (as location
    aliases defined after the scene). ``extra`` adds computed attributes
    (name, expression) to entities without changing the scene.
    ``dynamic_counts=False`` writes 0 instances for dynamic primitives: the
    text then describes what does not change from step to step. Matrices
    have the element type ``precision``, else the scene's
    (``config.precision`` unless the scene sets its own)."""
    located = _Locations(locations)
    text = _emit(scene, located, extra, dynamic_counts, precision)
    return text + located.table()


#: Each scene's kernel IR (without extra attributes) by element type, with
#: the structure count it was emitted at: evaluating the same scene again
#: (the line search, collision detection, assembly: many times a Newton
#: iteration) emits nothing until the scene changes.
_KERNEL_IRS: StateKey[Dict[str, Tuple[int, KernelIR]]] = StateKey(
    "the kernel IR per precision, and the structure it is of")


def kernel_ir(scene: Scene,
              extra: Optional[Dict[Entity, List[Tuple[str, Attribute]]]] = None,
              precision: Optional[str] = None,
              differentiated: Sequence[Attribute] = ()) -> KernelIR:
    """The IR that kernels are compiled from: the scene with its source
    locations kept apart (:class:`KernelIR`), and without what changes
    between Newton iterations. Kernels take instance counts at launch and
    read connectivities, union offsets and values from buffers, so dynamic
    primitives are written with 0 instances: a new number of collision
    pairs gives the same text, which the compiled libraries are cached
    by. ``differentiated`` lists stored attributes that are not targets
    (constants, usually) to differentiate against as well: they are written
    as variables and minimised over with the targets, after them, so that
    the derivative kernels also take derivatives with respect to them (the
    adjoint's mixed derivatives, yasps.solve.adjoint)."""
    element = config.resolve_precision(
        precision if precision is not None else scene.precision)
    cacheable = not extra and not differentiated
    if cacheable:
        cached = scene.state.setdefault(_KERNEL_IRS, dict).get(element)
        if cached is not None and \
                cached[0] == introspect.structure_revision(scene):
            return cached[1]
    located = _Locations(True)
    ir = KernelIR(_emit(scene, located, extra, False, element, differentiated),
                  located.table())
    if cacheable:
        scene.state.setdefault(_KERNEL_IRS, dict)[element] = \
            (introspect.structure_revision(scene), ir)
    return ir
