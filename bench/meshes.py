"""Reading the tetrahedral meshes of ../shared/data (Gmsh 2.2 ASCII)."""

from __future__ import annotations

from pathlib import Path
from typing import Tuple

import numpy as np

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def read_gmsh_tets(path: Path) -> Tuple[np.ndarray, np.ndarray]:
    """Vertices (N, 3) float64 and tets (M, 4) int32 (0-based) of a Gmsh 2.2
    ASCII file; elements other than 4-node tets are skipped."""
    lines = Path(path).read_text().split("\n")
    i = lines.index("$Nodes")
    count = int(lines[i + 1])
    nodes = np.array([l.split() for l in lines[i + 2:i + 2 + count]], float)
    ids = nodes[:, 0].astype(np.int64)
    index = np.full(ids.max() + 1, -1, dtype=np.int64)
    index[ids] = np.arange(count)
    j = lines.index("$Elements")
    tets = []
    for line in lines[j + 2:j + 2 + int(lines[j + 1])]:
        fields = line.split()
        if fields[1] == "4":
            tags = int(fields[2])
            tets.append([int(v) for v in fields[3 + tags:7 + tags]])
    tets = index[np.array(tets, dtype=np.int64)]
    return nodes[:, 1:4].copy(), tets.astype(np.int32)


def bunny(size: str = "19k") -> Tuple[np.ndarray, np.ndarray]:
    return read_gmsh_tets(DATA / f"bunny-{size}.msh")
