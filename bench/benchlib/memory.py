"""The peak resident memory of this process."""

from __future__ import annotations

import resource
from pathlib import Path


def peak_rss_kb() -> int:
    """This process's peak resident set size in kB: the kernel's VmHWM of
    its own address space. ``getrusage``'s ru_maxrss is not that on Linux:
    it keeps the peak of the process before its exec, so a side process
    started by a bench that had grown (checking frames with ipctk, say)
    reported the bench's size instead of its own."""
    status = Path("/proc/self/status")
    if status.exists():
        for line in status.read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
