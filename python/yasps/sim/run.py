"""Running a simulation to files: frames stepped with progress, each body's
surface as a ParaView series, pictures of chosen frames, a video, and a
summary (Newton and CG iterations, the closest distance over the run, the
time per stage). The examples share this instead of each writing its own
loop."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from ..frontend.attribute import Attribute
from ..solve.prepare import compile_scene
from .newton import ImplicitEuler, NewtonReport
from .output import (SurfaceRecorder, render_surfaces, render_surfaces_array,
                     write_video)

Color = Tuple[float, float, float]


@dataclass
class Body:
    """A surface to write and draw: the attribute of its vertices' world
    positions (data or computed, (N, 3, 1)), its triangles and a colour."""
    positions: Attribute
    faces: np.ndarray
    color: Color = (0.7, 0.7, 0.7)

    def now(self) -> np.ndarray:
        """The vertices' positions now, (N, 3)."""
        value = (self.positions.value if self.positions.kind in
                 ("data", "constant") else self.positions.compute().value)
        return np.ascontiguousarray(value[:, :, 0])


@dataclass
class RunSummary:
    """What :func:`simulate` did."""
    frames: int
    report: NewtonReport
    #: the smallest distance between surface primitives (and to half-spaces)
    #: over all frames, inf without contact or when nothing came within dhat
    min_distance: float
    #: whether some frame had an intersection (by the contact's ipctk check)
    intersections: bool
    seconds: float
    files: Dict[str, Path] = field(default_factory=dict)

    def line(self) -> str:
        """One line: frames, Newton and CG iterations, closest distance."""
        r = self.report
        unconverged = r.unconverged_text()
        return (f"{self.frames} frames in {self.seconds:.1f} s, "
                f"{r.iterations} Newton iterations, {sum(r.cg_iterations)} CG "
                f"iterations, min distance {self.min_distance:.3g} m, "
                f"{'INTERSECTIONS FOUND' if self.intersections else 'no intersections'}"
                + (f", {unconverged}" if unconverged else ""))

    def stages(self) -> str:
        """The time per stage, one line each with its share."""
        spent = sum(self.report.seconds.values()) or 1.0
        return "\n".join(f"  {stage:12} {seconds:8.2f} s  "
                         f"{100 * seconds / spent:5.1f}%"
                         for stage, seconds in self.report.seconds.items())


def _bounds(positions: Sequence[np.ndarray], margin: float = 0.05):
    """Bounds around all positions, with a margin of the diagonal."""
    lo = np.min([p.min(axis=0) for p in positions], axis=0)
    hi = np.max([p.max(axis=0) for p in positions], axis=0)
    pad = margin * np.linalg.norm(hi - lo)
    return tuple(lo - pad), tuple(hi + pad)


def simulate(stepper: ImplicitEuler, bodies: Mapping[str, Body], frames: int,
             output: Path, contact=None, stills: int = 4,
             bounds=None, view=(25.0, -60.0), video: bool = True,
             progress: bool = True, size=(640, 480),
             on_frame: Optional[Callable[[int, NewtonReport], None]] = None
             ) -> RunSummary:
    """Steps ``frames`` frames of ``stepper`` and writes ``output``: a VTU
    series per body (``<body>.pvd``), ``stills`` pictures
    (``frame_<n>.png``, evenly spread, the last frame included), and
    ``contact.mp4`` (or a GIF) if ``video``. With ``contact``, the closest
    distance and intersections are checked after every frame. ``bounds``
    (of the pictures; default: around the first frame, grown to hold the
    bodies' fall) keep every frame in one view. ``on_frame(frame,
    report)`` runs after each frame."""
    output = Path(output)
    recorder = SurfaceRecorder(output, {k: b.faces for k, b in bodies.items()})

    def meshes(P: Dict[str, np.ndarray]):
        return [(P[k], b.faces, b.color) for k, b in bodies.items()]

    def now() -> Dict[str, np.ndarray]:
        return {k: b.now() for k, b in bodies.items()}

    # Every kernel up front, the bodies' computed positions included: the
    # stage table's ``compile`` holds all the compiling there is.
    shown = [b.positions for b in bodies.values()
             if b.positions.kind not in ("data", "constant")]
    compile_seconds = compile_scene(
        stepper.scene, also=shown + ([stepper.contact.positions]
                                     if stepper.contact is not None else []),
        progress=progress, contact=stepper.contact).seconds
    first = now()
    planes = contact.halfspaces.planes() if contact is not None else []
    if bounds is None:
        bounds = _bounds(list(first.values()), margin=0.15)
    chosen = sorted({max(1, round(frames * (k + 1) / stills))
                     for k in range(stills)}) if stills else []
    images: List[np.ndarray] = []
    kept: Dict[int, Dict[str, np.ndarray]] = {}
    closest, crossed = float("inf"), False
    recorder.record(0.0, first)
    start = time.perf_counter()

    def frame_done(frame: int, report: NewtonReport) -> None:
        nonlocal closest, crossed
        P = now()
        recorder.record(frame * stepper.dt, P)
        if contact is not None:
            closest = min(closest, contact.min_distance())
            crossed = crossed or contact.has_intersections()
        if video:
            images.append(render_surfaces_array(meshes(P), bounds=bounds,
                                                view=view, size=size,
                                                halfspaces=planes))
        if frame in chosen:
            kept[frame] = P
        if on_frame is not None:
            on_frame(frame, report)

    total = stepper.run(frames, on_frame=frame_done, progress=progress)
    total.seconds["compile"] += compile_seconds
    seconds = time.perf_counter() - start
    files: Dict[str, Path] = {k: recorder.series_path(k) for k in bodies}
    for frame, P in kept.items():
        files[f"frame_{frame}"] = render_surfaces(
            output / f"frame_{frame:04d}.png", meshes(P), bounds=bounds,
            view=view, title=f"t = {frame * stepper.dt:.2f} s",
            halfspaces=planes)
    if video and images:
        files["video"] = write_video(output / "contact.mp4", images, fps=25)
    return RunSummary(frames, total, closest, crossed, seconds, files)
