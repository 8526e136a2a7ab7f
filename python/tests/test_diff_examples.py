"""The examples of examples/diff recover what made their measurements:
Young's modulus to 1%, the landing point to 1 mm."""

from __future__ import annotations

import sys

import numpy as np

from conftest import REPO

sys.path.insert(0, str(REPO / "examples" / "diff"))

import bounce  # noqa: E402
import youngs_modulus  # noqa: E402


def test_the_fit_recovers_youngs_modulus():
    history = youngs_modulus.fit(frames=25, iterations=20, verbose=False)
    assert abs(history.youngs[-1] / youngs_modulus.TRUE_YOUNG - 1) < 0.01
    assert history.losses[-1] < 1e-3 * history.losses[0]


def test_the_throw_lands_on_the_target():
    history, target = bounce.optimise(frames=60, iterations=15, verbose=False)
    miss = np.linalg.norm((history.paths[-1][-1] - target)[:2])
    assert miss < 1e-3
    # It started far off: the wall's bounce is part of what was found.
    assert np.linalg.norm((history.paths[0][-1] - target)[:2]) > 0.1
