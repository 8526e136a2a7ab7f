"""`pip install .` into a fresh virtual environment gives an importable
package whose extension works without the source tree; a source checkout,
once built, imports from any folder."""

import os
import subprocess
import sys
import venv

from conftest import REPO


def test_pip_install_into_fresh_venv(tmp_path):
    env_dir = tmp_path / "venv"
    venv.EnvBuilder(with_pip=True).create(env_dir)
    python = env_dir / "bin" / "python"
    subprocess.run([str(python), "-m", "pip", "install", "-q", str(REPO)],
                   check=True, capture_output=True, text=True)
    check = ("import yasps, yasps.compiler as c, pathlib;"
             "assert 'site-packages' in yasps.__file__, yasps.__file__;"
             "s = yasps.scene('s'); m = s.addMesh('m');"
             "p = m.addPrimitive('p', numInstances=1);"
             "x = p.addAttribute('x', rows=3);"
             "s.addEnergy(p.addAttribute('e', computed_attribute=x.squaredNorm()));"
             "print(s.ir())")
    out = subprocess.run([str(python), "-c", check], check=True,
                         capture_output=True, text=True, cwd=tmp_path).stdout
    assert "yasps.energy @m::@p::@e" in out


def test_the_build_lets_yasps_be_imported_from_any_folder():
    """scripts/build.sh (which the README's commands and CI run first)
    lists the checkout in the interpreter's site-packages: yasps and its
    compiled extensions import from / without PYTHONPATH."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "YASPS_BUILD_DIR")}
    out = subprocess.run(
        [sys.executable, "-c",
         "import yasps, yasps._native as n; n.load('_yasps_compiler'); "
         "n.load('_yasps_runtime'); print(yasps.__file__)"],
        capture_output=True, text=True, cwd="/", env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().endswith("yasps/__init__.py")


def test_registering_a_checkout_writes_one_pth_file(tmp_path, monkeypatch):
    """The .pth file names the checkout's python/ folder, in the
    interpreter's site-packages, else in the user's."""
    sys.path.insert(0, str(REPO / "scripts"))
    try:
        import register_checkout
    finally:
        sys.path.pop(0)
    purelib, user = tmp_path / "site", tmp_path / "user"
    monkeypatch.setattr(register_checkout.sysconfig, "get_paths",
                        lambda: {"purelib": str(purelib)})
    monkeypatch.setattr(register_checkout.site, "getusersitepackages",
                        lambda: str(user))
    target = register_checkout.register(REPO)
    assert target == purelib / "yasps-checkout.pth"
    assert target.read_text() == str((REPO / "python").resolve()) + "\n"
    target.unlink()
    purelib.rmdir()
    purelib.write_text("not a folder")  # site-packages not writable
    target = register_checkout.register(REPO)
    assert target == user / "yasps-checkout.pth"


def test_each_subpackage_has_an_extra_of_pinned_packages():
    import re
    import tomllib

    with open(REPO / "pyproject.toml", "rb") as f:
        extras = tomllib.load(f)["project"]["optional-dependencies"]
    assert {"contact", "sim", "sweep"} <= set(extras)
    assert set(extras["sim"]) == set(extras["meshes"]) | set(extras["pictures"])
    pinned = {m.group(1).lower() for m in re.finditer(
        r"^([A-Za-z0-9_.-]+)==", (REPO / "requirements.txt").read_text(), re.M)}
    for name, wanted in extras.items():
        for requirement in wanted:
            package = re.split(r"[<>=!\[ ]", requirement)[0].lower()
            assert package in pinned, \
                f"extra {name!r} needs {package}, which requirements.txt does not pin"
