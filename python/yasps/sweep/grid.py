"""Parameter sets from a grid description (the command line's JSON)."""

from __future__ import annotations

import itertools
from typing import Any, Dict, List
from ..frontend.errors import ArgumentError


def parameter_sets(grid: Any) -> List[Dict[str, Any]]:
    """The runs of a grid file: a list of parameter objects as they are, or
    an object of value lists as their product (in the keys' order)."""
    if isinstance(grid, list):
        return [dict(p) for p in grid]
    if isinstance(grid, dict):
        names = list(grid)
        values = [v if isinstance(v, list) else [v] for v in grid.values()]
        return [dict(zip(names, combo)) for combo in itertools.product(*values)]
    raise ArgumentError("the grid must be a list of objects or an object of "
                        "lists")
