"""yasps.sweep on a local Ray with 2 workers: results equal to running the
scenes one by one, kernels compiled once for the sweep, failures reported
and retried while the others finish, a resumed sweep skipping finished
runs, time limits, and the command line."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

import yasps

ray = pytest.importorskip("ray")

from conftest import REPO  # noqa: E402
import sweep_cases  # noqa: E402
from yasps import sweep  # noqa: E402
from yasps._native import BUILD_DIR  # noqa: E402

#: Variants of one scene (friction on in every one: without it the scene
#: has no friction energy, and so other kernels).
GRID = [{"mu": 0.05, "steps": 4}, {"mu": 0.3, "steps": 4},
        {"mu": 0.6, "steps": 4}, {"mu": 0.3, "angle": 15.0, "steps": 4},
        {"mu": 0.1, "steps": 4, "fail": "once"},
        {"mu": 0.2, "steps": 4, "fail": "always"}]


def test_a_sweep_runs_compiles_once_retries_and_resumes(tmp_path,
                                                       monkeypatch):
    monkeypatch.setattr(yasps.config, "cache_dir", str(tmp_path / "cache"))
    # The build tree as a relative path, as `YASPS_BUILD_DIR=build` gives
    # it: the workers, which run each simulation in its own folder, must
    # still find the extensions.
    monkeypatch.setenv("YASPS_BUILD_DIR", os.path.relpath(BUILD_DIR))
    out = tmp_path / "sweep"
    result = sweep.run(sweep_cases.simulate, GRID, workers=2, output=out,
                       retries=1, progress=False)
    rows = {r["id"]: r for r in result.rows}
    assert len(rows) == len(GRID)
    by_params = [rows[sweep.run_id(p)] for p in GRID]
    *fine, flaky, broken = by_params
    # The one that always raises is reported after its retry; the others,
    # the one that failed once included, finished.
    assert broken["status"] == "error" and broken["attempts"] == 2
    assert "this run always fails" in broken["error"]
    assert flaky["status"] == "ok" and flaky["attempts"] == 2, flaky["error"]
    assert all(r["status"] == "ok" and r["attempts"] == 1 for r in fine)
    # Equal to running them here, one by one.
    for params, row in zip(GRID[:5], fine + [flaky]):
        alone = sweep_cases.slope({k: v for k, v in params.items()
                                   if k != "fail"})
        np.testing.assert_allclose(row["outputs"]["final"], alone["final"],
                                   rtol=0, atol=1e-12)
        assert row["outputs"]["lowest"] > 0.0
        assert row["newton_iterations"] > 0 and row["cg_iterations"] > 0
    # One run compiled the kernels; every other loaded them.
    compiled = [r["kernels_compiled"] for r in fine + [flaky]]
    assert sorted(compiled)[-1] > 0 and sorted(compiled)[:-1] == [0] * 4
    # The files: each run's folder, the manifest and the table.
    assert (out / "manifest.json").exists() and (out / "results.csv").exists()
    assert "attempted" in flaky["files"]
    # Resumed: finished runs are skipped, the failed one is run again.
    again = sweep.run(sweep_cases.never, GRID, workers=2, output=out,
                      retries=0, progress=False)
    redone = {r["id"]: r for r in again.rows}
    assert all(redone[k] == rows[k] for k in rows if k != broken["id"])
    assert "a finished run was run again" in redone[broken["id"]]["error"]


def test_a_run_past_its_time_limit_is_stopped(tmp_path):
    result = sweep.run(sweep_cases.sleeper, [{"seconds": 60},
                                             {"seconds": 0}],
                       workers=2, output=tmp_path, retries=0, timeout=3.0,
                       progress=False)
    slow, quick = result.rows
    assert slow["status"] == "timeout" and "time limit of 3 s" in slow["error"]
    assert quick["status"] == "ok" and quick["outputs"] == {"slept": 0}


def test_the_command_line_runs_a_grid(tmp_path):
    grid = tmp_path / "grid.json"
    grid.write_text(json.dumps({"a": [1, 2], "b": 10}))
    script = tmp_path / "my_scene.py"
    script.write_text("def simulate(params):\n"
                      "    return {'sum': params['a'] + params['b']}\n")
    out = subprocess.run(
        [sys.executable, "-m", "yasps.sweep", str(script), "--grid",
         str(grid), "--workers", "2", "--output", str(tmp_path / "out")],
        env=dict(os.environ, PYTHONPATH=str(REPO / "python")),
        capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "2 of 2 runs finished" in out.stdout
    assert '{"sum": 11}' in out.stdout and '{"sum": 12}' in out.stdout
    assert sweep.parameter_sets({"a": [1, 2], "b": [3]}) == [
        {"a": 1, "b": 3}, {"a": 2, "b": 3}]
