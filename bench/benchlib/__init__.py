"""The benches' shared library.

Meshes, timing, the scenes and energies several bench scripts measure, and
the JSON results (``results.py``) that ``scripts/gen_bench_tables.py``
turns into the tables in ``docs/``. Scripts live in ``bench/`` and import
from here only (``test_bench_layout.py`` holds it); nothing here imports a
script.

A script calls ``use_this_checkout()`` before it imports yasps, so that it
measures the yasps beside it, not another checkout registered with the
interpreter.
"""

from __future__ import annotations

import sys
from pathlib import Path

#: bench/ and the checkout's root.
BENCH = Path(__file__).resolve().parent.parent
ROOT = BENCH.parent



def use_this_checkout() -> None:
    """Puts this checkout's ``python/`` first on ``sys.path``."""
    python = str(ROOT / "python")
    if python in sys.path:
        sys.path.remove(python)
    sys.path.insert(0, python)
