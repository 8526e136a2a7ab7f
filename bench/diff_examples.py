#!/usr/bin/env python3
"""The cost of the adjoint against the forward run, on the two examples of
examples/diff: a recorded forward run of implicit Euler with contact
against one backward pass over it (``ImplicitEuler.backward``).

Each example runs twice in one process; the second, with every kernel
compiled, is timed (the first backward compiles the adjoint's kernels
once per scene structure). The forward time is that of the recorded runs
the fit makes (not its line-search trials); bounce.py makes two backward
passes per run (one per coordinate of the landing point).

    python3 bench/diff_examples.py [--json bench/results/diff_examples.json]
"""

from __future__ import annotations

import argparse
import sys

import benchlib

benchlib.use_this_checkout()
from benchlib import ROOT  # noqa: E402
from benchlib.results import Results, add_json_argument  # noqa: E402

sys.path.insert(0, str(ROOT / "examples" / "diff"))

import bounce  # noqa: E402
import youngs_modulus  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    add_json_argument(parser, "diff_examples")
    args = parser.parse_args()
    rows = []
    for name, run in (
            ("youngs_modulus.py", lambda: youngs_modulus.fit(
                25, 20, verbose=False)),
            ("bounce.py", lambda: bounce.optimise(60, 15, verbose=False)[0])):
        run()                                   # compiles every kernel
        history = run()
        forward = history.forward_seconds / history.forward_runs
        backward = history.backward_seconds / history.backward_passes
        rows.append([name, history.forward_runs, history.backward_passes,
                     forward, backward, backward / forward])
        print(f"{name}: {history.forward_runs} recorded runs, "
              f"{history.backward_passes} backward passes; forward "
              f"{forward:.3f} s a run, backward {backward:.3f} s a pass "
              f"({backward / forward:.2f}x)", flush=True)
    results = Results("diff_examples")
    results.table("cost", ["example", "recorded runs", "backward passes",
                           "forward (s/run)", "backward (s/pass)",
                           "backward / forward"], rows,
                  ["", "", "", "{:.3f}", "{:.3f}", "{:.2f}x"],
                  note="Kernels compiled; one process, both timed in turn.")
    print(f"results: {results.write(args.json)}")


if __name__ == "__main__":
    main()
