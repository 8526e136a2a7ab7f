"""One error type (beside test_errors.py, which checks the messages): every
error the package raises for a user's mistake is
a YaspsError (and, for compatibility, the built-in error it replaces): no
module raises a bare ValueError, KeyError, IndexError or TypeError, and the
cases a review found raise yasps errors with their message unquoted."""

import ast

import pytest

import yasps
from conftest import REPO

BUILT_INS = {"ValueError", "KeyError", "IndexError", "TypeError"}


def test_no_module_raises_a_bare_built_in_error():
    found = []
    for path in sorted((REPO / "python" / "yasps").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Raise) and isinstance(node.exc, ast.Call) \
                    and getattr(node.exc.func, "id", None) in BUILT_INS:
                found.append(f"{path.relative_to(REPO)}:{node.lineno}")
    assert found == []


def test_the_reviewed_mistakes_raise_yasps_errors():
    s = yasps.scene("errors")
    p = s.addMesh("m").addPrimitive("p", numInstances=2)
    h = p.addAttribute("h", rows=3, cols=3)
    with pytest.raises(yasps.ArgumentError, match="bogus") as info:
        h.project("bogus")
    assert isinstance(info.value, ValueError)
    with pytest.raises(yasps.YaspsError, match="f16"):
        yasps.scene("f16", precision="f16")
    with pytest.raises(yasps.IndexRangeError) as index:
        h.row(5)
    assert isinstance(index.value, IndexError)
    with pytest.raises(yasps.NameLookupError) as name:
        p["nope"]
    assert isinstance(name.value, KeyError)
    assert str(name.value).startswith("primitive")  # a sentence, unquoted


def test_names_that_members_would_shadow_are_refused():
    """scene.<mesh> and mesh.<primitive> reach meshes and primitives by
    name; a name the entity's own members take would be unreachable."""
    s = yasps.scene("shadowed")
    for name in ("name", "path", "scene", "meshes"):
        with pytest.raises(yasps.SceneError, match="member of Scene"):
            s.addMesh(name)
    m = s.addMesh("m")
    for name in ("parent", "primitives", "kind"):
        with pytest.raises(yasps.SceneError, match="member of Mesh"):
            m.addPrimitive(name)
    assert m.addPrimitive("pose").name == "pose"


@pytest.mark.parametrize("name, value", [
    ("separate_reduced_hessians", "yes"), ("precision", "f16"),
    ("gpu_derivatives", 1), ("opt_level", 4), ("num_threads", -1),
    ("backend", "tpu"), ("cache_dir", 3)])
def test_config_settings_are_checked_when_set(name, value):
    """A wrong setting fails where it is set (it used to fail later: a
    KeyError deep in the compiler for separate_reduced_hessians = "yes"),
    and the setting keeps its value."""
    before = getattr(yasps.config, name)
    with pytest.raises(yasps.ArgumentError, match=f"config.{name} must be"):
        setattr(yasps.config, name, value)
    assert getattr(yasps.config, name) == before


def test_the_runtimes_argument_errors_are_yasps_errors():
    """A C++ std::invalid_argument from the runtime extension reaches
    Python as yasps.ArgumentError (a ValueError still), not a bare
    ValueError."""
    import numpy as np
    from yasps.runtime.native import native
    from yasps.sim import cloth_grid

    verts, faces = cloth_grid(2, size=0.3)
    mesh = native().ContactMesh(verts, np.zeros((0, 2), np.int32),
                                np.zeros((0, 3), np.int32))
    with pytest.raises(yasps.ArgumentError, match="positions") as error:
        native().contact_candidates(mesh, verts[:3], verts[:3], 0.1)
    assert isinstance(error.value, ValueError)
    with pytest.raises(yasps.ArgumentError, match="inflation"):
        native().contact_candidates(mesh, verts, verts, -1.0)
