#!/usr/bin/env python3
"""A gripper from URDF closes on a soft cube with friction, lifts it and
holds it, moved only by its joint drives.

The gripper (`urdf/gripper.urdf`: a palm on a vertical prismatic lift, two
fingers sliding towards each other) is an articulated body in joint
coordinates (`yasps.articulated`): its links' surfaces are computed from
three joint coordinates, in IPC contact (with friction 0.5) with a soft
stable Neo-Hookean cube and the ground. PD drives close the fingers past
the cube's faces, so that they squeeze it, then raise the lift; the
fingers' limits are barriers never crossed. The lift drive's force, read
each frame, carries the palm, the fingers and the cube.

    python3 examples/articulated/gripper.py [--frames 110] [--output DIR]
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
from yasps.articulated import transform  # noqa: E402
from yasps.sim import simulate  # noqa: E402

CUBE = 0.05            # m, the cube's side
DENSITY = 500.0        # kg/m^3: 62.5 g
YOUNG, POISSON = 1e5, 0.4
FRICTION = 0.5
MOUNT = 0.085          # m: the palm's underside, the fingers' tips 3 mm up
SQUEEZE = 0.031        # finger travel: its inner face 6 mm into the cube
LIFT = 0.05            # m raised
#: frames of each phase: close, lift, hold
CLOSE, RAISE = 30, 40


def schedule(t: float) -> Dict[str, Dict[str, float]]:
    """The drives' targets at time t: fingers close over CLOSE frames, then
    the lift rises over RAISE frames and stays."""
    close = min(t / (CLOSE * DT), 1.0)
    rise = min(max(t / DT - CLOSE, 0.0) / RAISE, 1.0)
    speed = LIFT / (RAISE * DT) if 0.0 < rise < 1.0 else 0.0
    return {"positions": {"left_slide": SQUEEZE * close,
                          "right_slide": SQUEEZE * close, "lift": LIFT * rise},
            "velocities": {"lift": speed}}


def build() -> RobotRun:
    s = yasps.scene("gripper")
    robot = add_articulated_body(s, read_urdf(HERE / "urdf" / "gripper.urdf"),
                                 name="gripper",
                                 base=transform(translation=[0, 0, MOUNT]))
    cube = add_soft_box(s, "cube", 3, CUBE, [0.0, 0.0, 1e-3], DENSITY,
                        YOUNG, POISSON)
    return robot_and_box(
        s, robot, cube, FRICTION,
        stiffness={"lift": 3000.0, "left_slide": 300.0, "right_slide": 300.0},
        damping={"lift": 60.0, "left_slide": 6.0, "right_slide": 6.0},
        schedule=schedule, names=("gripper", "cube"))


def carried_mass(gripping: RobotRun) -> float:
    """The mass the lift carries: the palm, the fingers and the cube."""
    links = gripping.robot.tree.links
    return sum(links[name].mass for name in
               ("palm", "finger_left", "finger_right")) + gripping.box.mass


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--frames", type=int, default=110)
    parser.add_argument("--output", type=Path,
                        default=Path("out/articulated/gripper"))
    args = parser.parse_args()
    gripping = build()
    lift = gripping.robot.joint_names.index("lift")

    def report(frame: int, _) -> None:
        if frame % 10 == 9:
            height = gripping.robot.joint_positions()[lift] * 1e3
            bottom = gripping.box.body.x.value[:, 2, 0].min() * 1e3
            force = gripping.drives.torques()[lift]
            print(f"frame {frame + 1}: lift {height:.1f} mm, cube bottom "
                  f"{bottom:.1f} mm, lift force {force:.3f} N")

    summary = simulate(gripping.stepper, gripping.bodies, args.frames,
                       args.output, contact=gripping.contact,
                       bounds=((-0.1, -0.1, 0.0), (0.1, 0.1, 0.2)),
                       on_frame=report)
    print(summary.line())
    weight = carried_mass(gripping) * 9.81
    print(f"lift force {gripping.drives.torques()[lift]:.4f} N, weight "
          f"carried {weight:.4f} N")
    if summary.intersections:
        sys.exit(1)


if __name__ == "__main__":
    main()
