"""Tests run on any machine: none names a path of one machine (the
shared data is found beside the checkout, as ../shared/data)."""

import ast
import re
from pathlib import Path

TESTS = Path(__file__).resolve().parent

#: Absolute paths that exist on one machine only.
MACHINE_PATH = re.compile(r"^/(work|root|home|Users|mnt)/")


def machine_paths(source: str) -> list:
    """The string constants of ``source`` that are absolute paths of one
    machine, with their lines."""
    return [(node.lineno, node.value) for node in ast.walk(ast.parse(source))
            if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and MACHINE_PATH.match(node.value)]


def test_no_test_names_a_path_of_one_machine():
    # This file's own sample below is the one exception.
    found = {path.name: machine_paths(path.read_text())
             for path in sorted(TESTS.glob("*.py"))
             if path.name != Path(__file__).name}
    assert {name: paths for name, paths in found.items() if paths} == {}


def test_the_check_finds_one():
    assert machine_paths('BUNNY = "/work/shared/data/bunny.msh"\n') == \
        [(1, "/work/shared/data/bunny.msh")]
    assert machine_paths('path = tmp_path / "x"\n') == []
