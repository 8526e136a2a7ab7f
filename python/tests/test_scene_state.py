"""Per-scene state lives in one object the scene owns (``Scene.state``):
no module keeps a table of scenes, a dropped scene takes its state with
it, and ``lastSolve`` reads the state."""

from __future__ import annotations

import ast
import gc
import weakref
from pathlib import Path

import numpy as np
import pytest

import yasps
from yasps.frontend.state import SceneState, StateKey
from yasps.sim import add_elastic_tets, add_free_vertices

from conftest import REPO, box_mesh


def soft_box():
    verts, tets = box_mesh(1)
    s = yasps.scene("stateful")
    body = add_free_vertices(s.addMesh("soft"), verts, 1.0)
    add_elastic_tets(s.soft, body.x, verts * 1.1, tets, 1e4, 4e4, scale=1e-4)
    body.x_hat.updateValue(verts)
    s.addMinimizeTarget(body.x)
    return s


def test_a_solve_keeps_its_state_in_the_scene():
    s = soft_box()
    with pytest.raises(yasps.SceneError, match="has solved nothing yet"):
        s.lastSolve
    # Only what building registered: add_elastic_tets' tets, which steppers
    # check for inversions.
    assert s.state.held() == ["the tets whose inversion steppers report"]
    s.minimizeEnergy(tolerance=1e-8)
    s.evaluateEnergy()
    held = s.state.held()
    for what in ("kernel IR", "Newton system", "last point assembled",
                 "last solve's report", "total energy's plan"):
        assert any(what in h for h in held), (what, held)
    assert s.lastSolve["converged"]
    assert "last solve" in repr(s.state)


def test_a_dropped_scene_takes_its_state_with_it():
    s = soft_box()
    s.minimizeEnergy(tolerance=1e-8)
    s.evaluateEnergy()
    dropped = weakref.ref(s)
    del s
    gc.collect()
    assert dropped() is None


def test_state_keys_are_typed_slots():
    state = SceneState()
    key, other = StateKey[list]("a list"), StateKey[list]("another list")
    assert state.get(key) is None and key not in state
    state.setdefault(key, list).append(1)
    state.setdefault(key, list).append(2)
    assert state.get(key) == [1, 2] and state.get(other) is None
    assert state.pop(key) == [1, 2] and state.held() == []


def test_state_is_a_reserved_name():
    s = yasps.scene("reserved")
    for name in ("state", "lastSolve"):
        with pytest.raises(yasps.SceneError, match="member of Scene"):
            s.addMesh(name)


def test_no_module_keeps_a_table_of_scenes():
    """Module-level weak tables keyed by scene were the old way; state is
    kept under a StateKey in Scene.state (backends may keep their own
    per-instance caches)."""
    found = []
    for path in sorted((REPO / "python" / "yasps").rglob("*.py")):
        tree = ast.parse(path.read_text())
        for node in tree.body:
            value = node.value if isinstance(node, (ast.Assign,
                                                    ast.AnnAssign)) else None
            if isinstance(value, ast.Call):
                name = ast.unparse(value.func)
                if name.split(".")[-1] in ("WeakKeyDictionary", "WeakSet",
                                           "WeakValueDictionary"):
                    found.append(f"{path.relative_to(REPO)}:{node.lineno}")
    assert found == []
