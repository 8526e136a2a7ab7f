"""The tetrahedral meshes of ../shared/data, read by the package's own
reader (``yasps.sim.read_tet_mesh``)."""

from __future__ import annotations

from typing import Tuple

import numpy as np

from benchlib import ROOT
from yasps.sim import read_tet_mesh

#: The data folder beside the checkout.
DATA = ROOT.parent / "shared" / "data"


def bunny(size: str = "19k") -> Tuple[np.ndarray, np.ndarray]:
    """The paper's bunny (``size``: "1.8k" or "19k" tets): vertices (N, 3)
    and tets (M, 4) int32 in the file's order, as the peers read it."""
    return read_tet_mesh(DATA / f"bunny-{size}.msh", reorder=False)
