#!/usr/bin/env python3
"""Writes the fuzz target's seed corpus (scripts/fuzz.sh) into a directory.

Two sources, so that the fuzzer starts from every construct a scene uses:

- the compiler's lit tests and the examples' IR files, one seed per
  ``// -----`` split, without their comment lines (RUN and CHECK lines
  only give the mutator text to waste time on);
- the IR of the examples' scenes as Python builds it (a dropped box, the
  angle-parameterised pendulum; a contact scene is too large, see
  MAX_SEED_BYTES).

    python3 scripts/fuzz_seeds.py OUTDIR
"""

from __future__ import annotations

import hashlib
import importlib.util
import sys
from pathlib import Path
from typing import Callable, Dict, Iterator

ROOT = Path(__file__).resolve().parents[1]

#: The longest input scripts/fuzz.sh gives the fuzzer (-max_len). The IR of
#: a contact scene (44 KB, four pair types with friction) is left out: every
#: one of its attributes lowered takes minutes in the sanitizer build, and
#: the lit tests hold its constructs in small pieces.
MAX_SEED_BYTES = 16384


def lit_pieces() -> Iterator[str]:
    """Each split of each .mlir file under test/ and examples/ir/ that holds
    a scene."""
    for path in sorted([*ROOT.glob("test/**/*.mlir"),
                        *ROOT.glob("examples/ir/*.mlir")]):
        for piece in path.read_text().split("// -----"):
            lines = [line for line in piece.splitlines()
                     if not line.lstrip().startswith("//")]
            text = "\n".join(lines).strip() + "\n"
            if "yasps.scene" in text:
                yield text


def load_example(relative: str):
    """The example script at ``relative`` as a module (its main not run)."""
    path = ROOT / relative
    sys.path.insert(0, str(path.parent))  # the paper scenes' common.py
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def example_scenes() -> Dict[str, Callable[[], str]]:
    """The examples' scenes at their smallest sizes, by name, as IR text."""
    def drop() -> str:
        return load_example("examples/drop.py").build(2)[0].ir()

    def pendulum() -> str:
        return load_example("examples/paper/pendulum.py").build()[0].ir()

    return {"drop": drop, "pendulum": pendulum}


def main() -> None:
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    seeds = list(lit_pieces())
    sys.path.insert(0, str(ROOT / "python"))
    seeds += [build() for build in example_scenes().values()]
    for text in seeds:
        if len(text.encode()) > MAX_SEED_BYTES:
            continue
        name = hashlib.sha1(text.encode()).hexdigest()[:16]
        (out / f"{name}.mlir").write_text(text)


if __name__ == "__main__":
    main()
