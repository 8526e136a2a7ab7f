"""Functions the sweep tests run in Ray workers (a module they can import):
the slope example, one that fails on its first attempt only, one that
always fails, and one that overruns any time limit."""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "examples"))

from sweep_slope import simulate as slope  # noqa: E402


def simulate(params):
    """The slope scene, or a failure as ``params["fail"]`` says: "once"
    raises unless a marker from an earlier attempt is in the run's folder
    (the working directory), "always" raises every time."""
    if params.get("fail") == "always":
        raise RuntimeError("this run always fails")
    if params.get("fail") == "once":
        marker = Path("attempted")
        if not marker.exists():
            marker.write_text("1")
            raise RuntimeError("the first attempt fails")
    return slope({k: v for k, v in params.items() if k != "fail"})


def never(params):
    """For a resumed sweep whose runs are all finished: must not run."""
    raise AssertionError("a finished run was run again")


def sleeper(params):
    time.sleep(float(params["seconds"]))
    return {"slept": params["seconds"]}
