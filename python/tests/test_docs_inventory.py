"""The docs' inventories against the code: every public name of the
package's user-facing modules, and every parameter of their functions and
classes, appears in docs/python.md; every layer of the package (the order
test_layers.py enforces) and every C++ conversion folder has its line in
docs/architecture.md."""

import inspect
import re

import pytest

import yasps
import yasps.articulated
import yasps.contact
import yasps.diff
import yasps.sim
import yasps.sweep
from conftest import REPO
from test_layers import LAYERS

PYTHON_MD = (REPO / "docs" / "python.md").read_text()
ARCHITECTURE_MD = (REPO / "docs" / "architecture.md").read_text()
WORDS = set(re.findall(r"[A-Za-z_][A-Za-z0-9_]*", PYTHON_MD))
MODULES = [yasps, yasps.sim, yasps.contact, yasps.articulated, yasps.diff,
           yasps.sweep]
#: Classes users get from the API rather than construct: their
#: constructors' parameters are not the API.
NOT_CONSTRUCTED = {"Attribute"}


def public_callables():
    for module in MODULES:
        for name in module.__all__:
            if name in NOT_CONSTRUCTED:
                continue
            obj = getattr(module, name)
            function = obj.__init__ if inspect.isclass(obj) else obj
            if callable(function):
                yield f"{module.__name__}.{name}", function


@pytest.mark.parametrize("module", MODULES, ids=lambda m: m.__name__)
def test_every_public_name_is_in_python_md(module):
    missing = [name for name in module.__all__ if name not in WORDS]
    assert not missing, f"docs/python.md does not name {missing}"


def test_every_parameter_is_in_python_md():
    missing = []
    for name, function in public_callables():
        try:
            parameters = inspect.signature(function).parameters
        except (TypeError, ValueError):  # built-ins without a signature
            continue
        # *args and **kwargs (the old spellings' catch-all) are not names.
        missing += [f"{name}({p})" for p, parameter in parameters.items()
                    if p != "self" and parameter.kind not in (
                        parameter.VAR_POSITIONAL, parameter.VAR_KEYWORD)
                    and not p.startswith("_") and p not in WORDS]
    assert not missing, f"docs/python.md does not name {missing}"


def test_every_layer_and_conversion_is_in_architecture_md():
    block = ARCHITECTURE_MD.split("python/yasps/\n", 1)[1].split("```")[0]
    listed = set(re.findall(r"\b([a-z_]+)(?:/|\.py)", block))
    missing = [layer for layer in LAYERS if layer not in listed]
    assert not missing, f"docs/architecture.md's layers lack {missing}"
    conversions = sorted(p.name for p in (REPO / "lib" / "Conversion").iterdir()
                         if p.is_dir())
    missing = [c for c in conversions
               if f"lib/Conversion/{c}" not in ARCHITECTURE_MD]
    assert not missing, f"docs/architecture.md does not name {missing}"
