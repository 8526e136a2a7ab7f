"""Imports a yasps extension module from the build tree (argv[1])."""

import importlib.util
import sys
from pathlib import Path


def load(name: str):
    """The extension module `name` built into the directory argv[1]."""
    path = next(Path(sys.argv[1]).glob(name + ".*"))
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
