"""`pip install .` into a fresh virtual environment gives an importable
package whose extension works without the source tree."""

import subprocess
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
