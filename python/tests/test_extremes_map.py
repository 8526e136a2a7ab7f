"""The stability map (bench/extremes.py): its reduced form, each axis' two
ends on one small scene, ends in no failure (NaN, intersection, a problem
nothing reported, a crash, a hang); its cells are classified as the
docs say; and what the map found is reported by yasps itself (inverted
tets warn ElementsInverted; stable Neo-Hookean refuses lam = 0)."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import yasps
from yasps.sim import (ElementsInverted, ImplicitEuler, add_elastic_tets,
                       add_free_vertices, box_tet_mesh, lumped_masses)

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "bench"))

from benchlib.extremes_cells import (FAILURES, Cell, Record,  # noqa: E402
                                     outcome)
from benchlib.extremes_map import reduced_map, run_cells  # noqa: E402


def test_the_reduced_map_ends_in_no_failure(tmp_path):
    """Every axis' two ends (stiffness, Poisson's ratio, mass ratio, time
    step, impact speed, contact distance, scene size, slivers, a start
    within dhat, f32) and friction: each cell holds, or yasps warned or
    stopped naming the cause; intersections are checked by ipctk in the
    bench, apart from yasps' queries."""
    out = tmp_path / "extremes.json"
    # 10 frames a cell, half the map's 20: the reduced map took 6.5 min of
    # the test command's cores at 20.
    done = subprocess.run(
        [sys.executable, str(REPO / "bench" / "extremes.py"), "--reduced",
         "--frames", "10", "--jobs", "1", "--budget", "300", "--json",
         str(out)],
        capture_output=True, text=True, timeout=1500)
    rows = json.loads(out.read_text())["values"]["rows"]
    assert len(rows) == len(reduced_map())
    failed = [(r["cell"], r["outcome"], r["reason"]) for r in rows
              if r["outcome"] in FAILURES]
    assert not failed, done.stdout[-3000:]
    assert done.returncode == 0, done.stderr[-3000:]
    # The map reaches what it is for: limits yasps reports.
    assert {r["outcome"] for r in rows} > {"holds"}


def test_outcomes_are_classified_as_documented():
    assert outcome(Record(frames=20)) == ("holds", "")
    assert outcome(Record(frames=20, inverted_tets=3))[0] == "silent"
    assert outcome(Record(frames=20, unconverged=1))[0] == "silent"
    assert outcome(Record(frames=20, unconverged=1,
                          warnings=["NewtonNotConverged: ..."]))[0] == "warned"
    assert outcome(Record(frames=3, nan=True,
                          warnings=["NewtonNotConverged: ..."]))[0] == "nan"
    assert outcome(Record(frames=20, intersecting_frames=2))[0] == \
        "intersection"
    assert outcome(Record(error=("SceneError", "named"),
                          yasps_error=True)) == ("stopped",
                                                 "SceneError: named")
    assert outcome(Record(error=("ValueError", "bare")))[0] == "crash"
    assert outcome(Record(error=("Hang", "no result")))[0] == "hang"


def test_a_cell_past_its_budget_is_a_hang_and_the_map_goes_on():
    # The budget counts a worker's start (importing yasps): 1 s let a
    # loaded 2-core machine record the crashing cell as a hang too.
    records = run_cells([Cell("soft", frames=10**6), Cell("nonsense")],
                        jobs=1, budget=15.0)
    assert [outcome(r)[0] for r in records] == ["hang", "crash"]


def _soft_box(name: str, speed: float, young: float):
    verts, tets = box_tet_mesh(2, size=0.1)
    s = yasps.scene(name)
    mesh = s.addMesh("soft")
    body = add_free_vertices(mesh, verts, lumped_masses(verts, tets, 1000.0))
    add_elastic_tets(mesh, body.x, verts, tets, *yasps.sim.lame(young, 0.3),
                     scale=1e-4)
    s.addMinimizeTarget([body.x])
    # The bottom layer held, the rest thrown at it.
    v = np.zeros_like(verts)
    v[verts[:, 2] > 0.01, 2] = -speed
    fixed = np.zeros(len(verts), dtype=bool)
    fixed[verts[:, 2] < 0.01] = True
    return ImplicitEuler(s, body.x, body.x_hat, dt=0.01, gravity=None,
                         fixed=fixed, velocities=v), tets


def test_inverted_tets_are_counted_and_warned_once():
    """A soft box's top thrown through its held bottom at 100 m/s inverts
    tets under stable Neo-Hookean (defined past J = 0): each report counts
    them (checked here from the positions) and one ElementsInverted
    warning names the primitive and what to change."""
    stepper, tets = _soft_box("thrown", speed=100.0, young=1e3)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        reports = [stepper.step() for _ in range(3)]
    x = stepper.targets[0].value.reshape(-1, 3)
    c = x[tets]
    volumes = np.einsum("ij,ij->i", np.cross(c[:, 1] - c[:, 0],
                                            c[:, 2] - c[:, 0]),
                        c[:, 3] - c[:, 0])
    assert reports[-1].inverted_tets == int((volumes <= 0).sum()) > 0
    inverted = [w for w in caught if w.category is ElementsInverted]
    assert len(inverted) == 1
    assert "of primitive 'soft.t' (stable_neo_hookean) inverted" in \
        str(inverted[0].message)
    assert "material='neo_hookean'" in str(inverted[0].message)


def test_a_gentle_step_inverts_nothing_and_says_nothing():
    stepper, _ = _soft_box("gentle", speed=0.1, young=1e5)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ElementsInverted)
        report = stepper.step()
    assert report.inverted_tets == 0


def test_stable_neo_hookean_refuses_lam_zero_and_names_why():
    verts, tets = box_tet_mesh(1, size=0.1)
    s = yasps.scene("poisson_zero")
    mesh = s.addMesh("soft")
    body = add_free_vertices(mesh, verts, 1.0)
    with pytest.raises(yasps.ArgumentError,
                       match=r"stable Neo-Hookean needs lam > 0.*"
                             r"material='fixed_corotated'"):
        add_elastic_tets(mesh, body.x, verts, tets, 1e4, 0.0)
    # The materials defined at lam = 0 take it.
    add_elastic_tets(mesh, body.x, verts, tets, 1e4, 0.0,
                     material="fixed_corotated")


def test_a_guarded_cell_inverts_nothing():
    """``--guard``: the soft box hit at 100 m/s, whose stable Neo-Hookean
    tets invert unguarded (the map's limits table), holds with every tet
    positive (the map's own count of signed volumes)."""
    from benchlib.extremes_cells import run_cell
    record = run_cell(Cell("soft", speed=100.0, guard=True))
    assert record.inverted_tets == 0
    assert outcome(record)[0] == "holds", outcome(record)
