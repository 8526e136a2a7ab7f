#!/usr/bin/env python3
"""Makes ``import yasps`` work from any folder with this interpreter: writes
``yasps-checkout.pth``, naming the checkout's ``python/`` folder, into the
interpreter's site-packages (or the user's, where those are not writable).
The package then finds its extensions in the checkout's ``build/`` (or in
``$YASPS_BUILD_DIR``). The file names the checkout built last.

    python3 scripts/register_checkout.py CHECKOUT [BUILD_DIR]
"""

from __future__ import annotations

import os
import site
import sys
import sysconfig
from pathlib import Path

PTH_NAME = "yasps-checkout.pth"


def register(checkout: Path) -> Path:
    """Writes the .pth file; returns where. Raises OSError if no
    site-packages folder is writable."""
    package_root = str((checkout / "python").resolve())
    errors = []
    for folder in (sysconfig.get_paths()["purelib"],
                   site.getusersitepackages()):
        try:
            os.makedirs(folder, exist_ok=True)
            target = Path(folder) / PTH_NAME
            target.write_text(package_root + "\n")
            return target
        except OSError as error:
            errors.append(f"{folder}: {error}")
    raise OSError("no site-packages folder is writable: " + "; ".join(errors))


def main() -> None:
    checkout = Path(sys.argv[1])
    target = register(checkout)
    print(f"import yasps: {checkout.resolve() / 'python'} (listed in {target})")
    if len(sys.argv) > 2 and \
            Path(sys.argv[2]).resolve() != (checkout / "build").resolve():
        print(f"  its extensions are in {sys.argv[2]}: set "
              f"YASPS_BUILD_DIR={sys.argv[2]} where you import it")


if __name__ == "__main__":
    main()
