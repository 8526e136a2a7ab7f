"""``python3 -m yasps.sweep my_scene.py --grid params.json --workers 8
--output out/``: runs ``simulate(params)`` of ``my_scene.py`` over the
parameter sets of ``params.json`` (a list of objects, or an object of lists
whose every combination is a run) and prints the table."""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
from importlib.machinery import ModuleSpec
from pathlib import Path
from typing import cast

from .grid import parameter_sets
from .runner import run


def load_simulate(script: Path):
    """``simulate`` of a script, imported as a module named after the file
    (the workers import it the same way, from the script's folder)."""
    sys.path.insert(0, str(script.resolve().parent))
    # None for a file without a Python suffix, which module_from_spec then
    # rejects (AttributeError); a spec it does give has its loader.
    spec = cast(ModuleSpec,
                importlib.util.spec_from_file_location(script.stem, script))
    module = importlib.util.module_from_spec(spec)
    sys.modules[script.stem] = module
    assert spec.loader is not None
    spec.loader.exec_module(module)
    if not callable(getattr(module, "simulate", None)):
        raise SystemExit(f"{script} defines no function simulate(params)")
    return module.simulate


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python3 -m yasps.sweep",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("script", type=Path)
    parser.add_argument("--grid", type=Path, required=True)
    parser.add_argument("--workers", type=int)
    parser.add_argument("--output", type=Path, default=Path("out/sweep"))
    parser.add_argument("--retries", type=int, default=1)
    parser.add_argument("--timeout", type=float)
    parser.add_argument("--address", help="a Ray cluster (default: local)")
    args = parser.parse_args(argv)
    result = run(load_simulate(args.script),
                 parameter_sets(json.loads(args.grid.read_text())),
                 workers=args.workers, output=args.output,
                 retries=args.retries, timeout=args.timeout,
                 address=args.address)
    for row in result.rows:
        print(row["id"], row["status"], f"{row.get('seconds', 0.0):.2f} s",
              json.dumps(row["params"]), json.dumps(row.get("outputs", {})))
    print(f"{len(result.rows) - len(result.failed)} of {len(result.rows)} "
          f"runs finished; table: {result.output / 'results.csv'}")
    return 1 if result.failed else 0


if __name__ == "__main__":
    sys.exit(main())
