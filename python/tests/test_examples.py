"""The Python examples the README's demo runs."""

import subprocess
import sys

from conftest import REPO


def test_two_bunnies_example_runs():
    out = subprocess.run([sys.executable, str(REPO / "examples" / "two_bunnies.py")],
                         check=True, capture_output=True, text=True).stdout
    assert "128 vertices in the union" in out
    assert "16 point-point pairs" in out
    assert "Hessians (16, 24, 24)" in out
    assert "pair 0 (affine-soft) has 15 real parameters" in out
