"""No input crashes the runtime extension: malformed arguments to its entry
points (contact queries, assembly and solves, Hessian compression) raise a
YaspsError. Each entry point runs a bounded random search
(runtime_fuzz_cases.py, seeds 0 .. CASES) in a child process, which a
crash cannot take the test run down with; what the search found is kept
below as tests of the inputs themselves."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import yasps
from yasps._native import runtime_module

from runtime_fuzz_cases import ENTRIES

HERE = Path(__file__).resolve().parent
#: Cases per entry point and run (YASPS_FUZZ_CASES for a longer search).
CASES = int(os.environ.get("YASPS_FUZZ_CASES", "400"))


@pytest.mark.parametrize("entry", sorted(ENTRIES))
def test_malformed_runtime_inputs_are_refused(entry):
    child = subprocess.run(
        [sys.executable, str(HERE / "runtime_fuzz_cases.py"), entry, "0",
         str(CASES)],
        capture_output=True, text=True, timeout=600,
        env=dict(os.environ, PYTHONPATH=os.pathsep.join(
            [str(HERE.parent)] + sys.path)))
    printed = child.stdout.split()
    last = printed[-1] if printed else "none"
    assert child.returncode == 0, (
        f"{entry}: seed {last} ended with status {child.returncode}: "
        f"{child.stdout[-500:]}{child.stderr[-2000:]}")


# ------------------------------------------------------ what it found

rt = runtime_module()
TET = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
TET_EDGES = np.array([[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]],
                     dtype=np.int32)
TET_FACES = np.array([[0, 1, 2], [0, 1, 3], [1, 2, 3], [0, 2, 3]],
                     dtype=np.int32)


def tet_mesh():
    return rt.ContactMesh(TET, TET_EDGES, TET_FACES)


def test_candidates_of_another_mesh_are_refused():
    """They indexed past the smaller mesh's faces: a segfault."""
    candidates = rt.contact_candidates(tet_mesh(), TET, TET, 1.0)
    assert len(candidates.face_vertex)
    small = rt.ContactMesh(TET[:3], TET_EDGES[:3], TET_FACES[:1])
    with pytest.raises(yasps.ArgumentError, match="another contact mesh"):
        rt.contact_collision_set(small, candidates, TET[:3], 0.1)
    with pytest.raises(yasps.ArgumentError, match="another contact mesh"):
        rt.contact_step_bound(small, candidates, TET[:3], TET[:3], 0.0)


@pytest.mark.parametrize("bad", [0.0, -0.1, float("nan"), float("inf")])
def test_a_contact_distance_that_is_no_distance_is_refused(bad):
    """dhat and the step bound's distance were taken as they came."""
    mesh = tet_mesh()
    candidates = rt.contact_candidates(mesh, TET, TET, 1.0)
    with pytest.raises(yasps.ArgumentError, match="dhat"):
        rt.contact_collision_set(mesh, candidates, TET, bad)
    if bad != 0.0:
        with pytest.raises(yasps.ArgumentError, match="distance to keep"):
            rt.contact_step_bound(mesh, candidates, TET, TET, bad)


def test_non_finite_rest_positions_are_refused():
    """They made NaN edge-edge mollifiers, unnoticed."""
    rest = TET.copy()
    rest[2, 1] = float("nan")
    with pytest.raises(yasps.ArgumentError, match="rest positions"):
        rt.ContactMesh(rest, TET_EDGES, TET_FACES)


def test_a_thread_count_past_the_limit_is_refused():
    """100,000 threads ended in a RuntimeError of the system's."""
    with pytest.raises(yasps.ArgumentError, match="thread count"):
        rt.contact_candidates(tet_mesh(), TET, TET, 1.0, 100000)


@pytest.mark.parametrize("offsets", [[3, 6, 9], [0, 6, 3], [0, 3, 3]])
def test_block_offsets_that_do_not_start_at_zero_and_grow_are_refused(
        offsets):
    """They indexed a table of the blocks' DoFs out of its bounds."""
    with pytest.raises(yasps.ArgumentError, match="GlobalSystem"):
        rt.GlobalSystem(np.array(offsets, dtype=np.int64),
                        [np.zeros((1, 3), dtype=np.int64)])


def test_a_size_past_a_container_is_an_argument_error():
    """std::length_error reached Python as a bare ValueError."""
    offsets = np.array([0, 3, 2 ** 62], dtype=np.int64)
    with pytest.raises(yasps.ArgumentError):
        rt.GlobalSystem(offsets, [])
