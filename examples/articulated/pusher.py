#!/usr/bin/env python3
"""A planar arm from URDF sweeps its paddle across a table and pushes a
soft box along it, with friction, by its shoulder's drive.

The arm (`urdf/pusher.urdf`: shoulder and elbow about z, a paddle welded
to the forearm) is an articulated body in joint coordinates; the box a
stable Neo-Hookean tet mesh resting on the table (a half-space). (An
affine box in the same contact UNION would make each contact pair's
Hessian 48 x 48 and projected in full, since the arm's positions are not
linear in its coordinates: its kernel exceeds the compiler's budget.) The shoulder's drive
turns the arm 0.9 rad over 1.5 s while the elbow's holds it straight; the
paddle meets the box after a third of the sweep and pushes it round.

    python3 examples/articulated/pusher.py [--frames 160] [--output DIR]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Dict

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "python"))

sys.path.insert(0, str(HERE))

import yasps  # noqa: E402
from robot_scenes import (DT, RobotRun, add_soft_box,  # noqa: E402
                    robot_and_box)
from yasps.articulated import add_articulated_body, read_urdf  # noqa: E402
from yasps.sim import simulate  # noqa: E402

BOX = 0.06            # m, the box's side
DENSITY = 300.0       # kg/m^3: 65 g
YOUNG, POISSON = 2e5, 0.4
RADIUS = 0.56         # m, the paddle's centre from the shoulder
START = 0.35          # rad, where the box sits round from the arm
SWEEP, SECONDS = 0.9, 1.5


def schedule(t: float) -> Dict[str, Dict[str, float]]:
    """The shoulder's targets: a sweep at a constant rate, then rest."""
    share = min(t / SECONDS, 1.0)
    rate = SWEEP / SECONDS if share < 1.0 else 0.0
    return {"positions": {"shoulder": SWEEP * share, "elbow": 0.0},
            "velocities": {"shoulder": rate, "elbow": 0.0}}


def build() -> RobotRun:
    s = yasps.scene("pusher")
    robot = add_articulated_body(s, read_urdf(HERE / "urdf" / "pusher.urdf"),
                                 name="arm")
    box = add_soft_box(s, "box", 2, BOX, [RADIUS * np.cos(START),
                                          RADIUS * np.sin(START), 1e-3],
                       DENSITY, YOUNG, POISSON)
    return robot_and_box(s, robot, box, 0.3, stiffness=300.0, damping=30.0,
                         schedule=schedule, names=("arm", "box"))


def box_angle(pushing: RobotRun) -> float:
    """The box's centre's angle round the shoulder (rad)."""
    centre = np.asarray(pushing.box.body.x.value, float)[:, :, 0].mean(axis=0)
    return float(np.arctan2(centre[1], centre[0]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=160)
    parser.add_argument("--output", type=Path,
                        default=Path("out/articulated/pusher"))
    args = parser.parse_args()
    pushing = build()
    summary = simulate(pushing.stepper, pushing.bodies, args.frames,
                       args.output, contact=pushing.contact,
                       bounds=((-0.1, -0.1, 0.0), (0.7, 0.7, 0.15)))
    print(summary.line())
    print(f"the box went round from {START:.3f} to {box_angle(pushing):.3f} "
          f"rad; the shoulder at {pushing.robot.joint_positions()[0]:.3f}")
    if summary.intersections:
        sys.exit(1)


if __name__ == "__main__":
    main()
