"""The package's layers: each module imports only its own layer and those
before it (frontend -> ir -> compiler -> runtime -> solve -> contact ->
sim -> articulated -> diff -> sweep), so the import graph has no cycle, and library code never decides
what to do by reading an error message's text."""

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "yasps"

#: Layers in order; the package root's errors, deprecated spellings, shared
#: settings and loader
#: come before every layer (they import no layer), the root's __init__
#: (which wires the layers together) after all of them.
LAYERS = ["errors", "deprecation", "config", "_native", "frontend", "ir", "compiler", "runtime",
          "solve", "contact", "sim", "articulated", "diff", "sweep"]


def module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def runtime_nodes(tree: ast.AST):
    """Every node that can run: all but the bodies of ``if TYPE_CHECKING``."""
    pending = [tree]
    while pending:
        node = pending.pop()
        yield node
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and ast.unparse(child.test) in (
                    "TYPE_CHECKING", "typing.TYPE_CHECKING"):
                pending += child.orelse
            else:
                pending.append(child)


def imports_of(path: Path, name: str = "") -> set:
    """The yasps modules a file imports anywhere it can run (also inside
    functions); ``name`` is its module name (default: from its path)."""
    name = name or module_name(path)
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = set()
    for node in runtime_nodes(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.startswith("yasps")}
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0:
                base = node.module or ""
            else:
                parts = package.split(".")
                base = ".".join(parts[:len(parts) - node.level + 1])
                if node.module:
                    base += "." + node.module
            if not base.startswith("yasps"):
                continue
            for alias in node.names:
                candidate = f"{base}.{alias.name}"
                found.add(candidate if modules().get(candidate) else base)
    return found


_modules = {}


def modules() -> dict:
    if not _modules:
        for path in PACKAGE.rglob("*.py"):
            _modules[module_name(path)] = path
    return _modules


def layer(module: str) -> int:
    parts = module.split(".")
    if len(parts) == 1:
        return len(LAYERS)  # the package's __init__
    return LAYERS.index(parts[1])


def graph() -> dict:
    return {name: {m for m in imports_of(path) if m in modules()}
            for name, path in modules().items()}


def test_every_module_belongs_to_a_layer():
    for name in modules():
        assert name == "yasps" or name.split(".")[1] in LAYERS, name


def test_layers_import_only_the_layers_before_them():
    for name, imported in graph().items():
        for other in imported:
            assert layer(other) <= layer(name), f"{name} imports {other}"


def test_the_import_graph_has_no_cycle():
    edges = graph()
    state = {}

    def visit(node, stack):
        state[node] = "open"
        for nxt in edges[node]:
            if nxt == node or (nxt.startswith(node + ".") and
                               modules()[node].name == "__init__.py"):
                continue  # a package importing its own submodules
            if state.get(nxt) == "open":
                raise AssertionError(" -> ".join(stack + [node, nxt]))
            if nxt not in state:
                visit(nxt, stack + [node])
        state[node] = "done"

    for node in edges:
        if node not in state:
            visit(node, [])


def test_the_checker_sees_function_level_imports(tmp_path):
    """An import in a function body counts; a type-checking one does not."""
    sample = tmp_path / "sample.py"
    sample.write_text("from typing import TYPE_CHECKING\n"
                      "if TYPE_CHECKING:\n    from ..ir import emit\n"
                      "def f():\n    from ..solve import minimize\n")
    assert imports_of(sample, "yasps.frontend.sample") == {
        "yasps.solve.minimize"}


def message_tests(path: Path) -> list:
    """Places that test the text of a caught exception (``"..." in
    str(err)``), as (line, source)."""
    tree = ast.parse(path.read_text())
    found = []
    for handler in ast.walk(tree):
        if not isinstance(handler, ast.ExceptHandler) or not handler.name:
            continue
        for node in ast.walk(handler):
            if not isinstance(node, ast.Compare):
                continue
            for side in [node.left] + node.comparators:
                if isinstance(side, ast.Call) and getattr(
                        side.func, "id", "") == "str" and any(
                        isinstance(a, ast.Name) and a.id == handler.name
                        for a in side.args):
                    found.append((node.lineno, ast.unparse(node)))
    return found


def test_library_code_does_not_branch_on_error_messages():
    for name, path in modules().items():
        assert message_tests(path) == [], name


def test_the_message_check_finds_one(tmp_path):
    sample = tmp_path / "sample.py"
    sample.write_text("try:\n    f()\nexcept ValueError as err:\n"
                      "    if 'no target' in str(err):\n        pass\n")
    assert message_tests(sample) == [(4, "'no target' in str(err)")]


def frontend_private_fields() -> set:
    """The private fields the frontend's classes keep (``self._x = ...``)."""
    found = set()
    for path in (PACKAGE / "frontend").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Attribute) and \
                    isinstance(node.ctx, ast.Store) and \
                    isinstance(node.value, ast.Name) and \
                    node.value.id == "self" and node.attr.startswith("_") \
                    and not node.attr.startswith("__"):
                found.add(node.attr)
    return found


def private_reads(path: Path, fields: set) -> list:
    """``obj._x`` in ``path`` for a field ``_x`` of ``fields``, on anything
    but ``self``: lines and names."""
    out = []
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Attribute) and node.attr in fields and not (
                isinstance(node.value, ast.Name) and
                node.value.id in ("self", "cls")):
            out.append(f"{path.name}:{node.lineno} .{node.attr}")
    return out


def test_only_the_frontend_reads_its_private_fields():
    """The layers above read the frontend's objects through their public
    members and frontend.introspect, never their private fields."""
    fields = frontend_private_fields()
    assert {"_symbols", "_values", "_structure", "_operands"} <= fields
    found = []
    for name, path in modules().items():
        if not name.startswith("yasps.frontend"):
            found += private_reads(path, fields)
    assert not found, found


def test_the_private_read_check_finds_one(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("def f(scene):\n    return scene._symbols\n")
    assert private_reads(bad, {"_symbols"}) == ["bad.py:2 ._symbols"]
