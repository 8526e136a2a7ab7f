"""The files of a GPU kit (bench/gpu_kit.py writes them, runtime/bench/Kit.h
and bench/gpu_peers.py read them) that the peers' side reads too."""

from __future__ import annotations

from pathlib import Path

import numpy as np


#: The SNH kit's input buffers: the tets' corners (4 points of 3 per tet)
#: and inverse rest shapes (column-major 3x3 per tet).
SNH_POSITIONS, SNH_INVERSES = "attr_m.v.x.npy", "attr_m.e.inv.npy"


def peer_inputs(kit: Path):
    """The formula's inputs (bench/benchlib/energy_cases.py's snh_positions) from the
    SNH kit's buffers: positions (N, 12) and row-major inverse rest shapes
    (N, 9)."""
    x = np.load(kit / SNH_POSITIONS).reshape(-1, 12)
    inverses = np.load(kit / SNH_INVERSES).reshape(-1, 3, 3)
    return x, np.ascontiguousarray(np.transpose(inverses, (0, 2, 1))).reshape(-1, 9)
