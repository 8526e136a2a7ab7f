"""The Python examples: those the README's demo runs, the soft boxes and
the cloth drape."""

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


def test_soft_boxes_example_runs():
    """Two frames of examples/soft_boxes.py: the boxes fall (the high one
    starts 3 cm above the low one: the gap closes) and stay above ground."""
    out = subprocess.run([sys.executable, str(REPO / "examples" / "soft_boxes.py"),
                          "--frames", "2"],
                         check=True, capture_output=True, text=True).stdout
    lines = [line for line in out.splitlines() if line.startswith("frame")]
    assert len(lines) == 2
    gaps = [float(line.split("gap")[1].split("mm")[0]) for line in lines]
    lowest = [float(line.split("lowest z")[1].split("cm")[0]) for line in lines]
    assert 0 < gaps[1] < gaps[0] < 30
    assert min(lowest) > 0


def test_cloth_drape_example_runs():
    """Two frames of examples/cloth_drape.py: the cloth falls from 21 cm
    toward the box's top at 20 cm."""
    out = subprocess.run([sys.executable, str(REPO / "examples" / "cloth_drape.py"),
                          "--frames", "2"],
                         check=True, capture_output=True, text=True).stdout
    lowest = [float(line.split("lowest z")[1].split("cm")[0])
              for line in out.splitlines() if line.startswith("frame")]
    assert len(lowest) == 2
    assert 20 < lowest[1] < lowest[0] < 21
