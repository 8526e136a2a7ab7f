"""Prints the shared libraries that extension module argv[2] in the
directory argv[1] needs (readelf -d), then 'end'."""

import subprocess
import sys
from pathlib import Path

module = next(Path(sys.argv[1]).glob(sys.argv[2] + ".*"))
dynamic = subprocess.run(["readelf", "-d", str(module)], check=True,
                         capture_output=True, text=True).stdout
for line in dynamic.splitlines():
    if "(NEEDED)" in line:
        print(line.split("[")[1].rstrip("]"))
print("end")
