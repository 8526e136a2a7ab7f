"""Process-wide settings of yasps.

- ``cache_dir``: where compiled kernels are kept between processes. From the
  environment variable ``YASPS_CACHE_DIR``; otherwise
  ``$XDG_CACHE_HOME/yasps`` or ``~/.cache/yasps``. ``None`` (or
  ``YASPS_CACHE_DIR=off``) keeps kernels in memory only.
- ``num_threads``: threads used to evaluate kernels on the CPU; 0 uses every
  core (or ``YASPS_NUM_THREADS`` if set).
- ``opt_level``: LLVM optimisation level of CPU kernels (0-3).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Optional


def _default_cache_dir() -> Optional[str]:
    value = os.environ.get("YASPS_CACHE_DIR")
    if value is not None:
        return None if value.lower() in ("", "off", "none", "0") else value
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return str(Path(base) / "yasps")


cache_dir: Optional[str] = _default_cache_dir()
num_threads: int = 0
opt_level: int = 3
