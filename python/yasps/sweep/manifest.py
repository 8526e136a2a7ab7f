"""The record of a sweep in its output folder (``manifest.json``): one
entry per parameter set, by a stable id of its parameters, so that an
interrupted sweep resumes where it stopped."""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any, Dict, List, Optional

#: Statuses of a run: finished, raised on every attempt, ran past its time
#: limit on every attempt.
STATUSES = ("ok", "error", "timeout")


def plain(value: Any) -> Any:
    """``value`` with NumPy scalars and arrays as Python numbers and lists
    (what JSON and CSV hold)."""
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if hasattr(value, "tolist"):
        return value.tolist()
    return value


def run_id(params: Dict[str, Any]) -> str:
    """A stable id of a parameter set: the same parameters give the same id
    in any process and order of keys."""
    text = json.dumps(plain(params), sort_keys=True)
    return hashlib.sha1(text.encode()).hexdigest()[:12]


class Manifest:
    """The runs of a sweep and what became of them, saved after every run
    (written to a temporary file and renamed, so that a sweep stopped at
    any moment leaves a readable manifest)."""

    def __init__(self, folder: Path, runs: Optional[Dict[str, dict]] = None):
        self.folder = Path(folder)
        self.runs: Dict[str, dict] = runs or {}

    @property
    def path(self) -> Path:
        return self.folder / "manifest.json"

    @classmethod
    def open(cls, folder: Path) -> "Manifest":
        """The folder's manifest, or an empty one."""
        path = Path(folder) / "manifest.json"
        if path.exists():
            return cls(folder, json.loads(path.read_text())["runs"])
        return cls(folder)

    def finished(self, key: str) -> bool:
        return self.runs.get(key, {}).get("status") == "ok"

    def record(self, key: str, entry: dict) -> None:
        self.runs[key] = plain(entry)
        self.save()

    def save(self) -> None:
        self.folder.mkdir(parents=True, exist_ok=True)
        tmp = self.path.with_suffix(".json.tmp")
        tmp.write_text(json.dumps({"runs": self.runs}, indent=1,
                                  sort_keys=True))
        os.replace(tmp, self.path)

    def rows(self, keys: List[str]) -> List[dict]:
        return [self.runs[k] for k in keys if k in self.runs]
