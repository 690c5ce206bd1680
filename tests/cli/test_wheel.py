"""The wheel ships presets/ and formats/: build it, install it into a fresh venv, and cook
with a bundled preset from a directory outside the source tree.

The fresh venv borrows its dependencies (numba, h5py, pxr, ...) from the environment running
the tests, so the test needs no network and passes whether that environment is a system
install or a venv (PEP 668 systems require one). ``--system-site-packages`` is not enough:
from inside a venv it exposes the base interpreter's packages, not the running venv's.
"""

from __future__ import annotations

import os
import subprocess
import sys
import venv
from pathlib import Path

import pytest

from tests.conftest import EXAMPLES, REPO


def running_site_packages() -> list[str]:
    """The package directories of the interpreter running the tests: its venv's, the base
    installation's when that venv has system site packages, the user's, Debian's dist-packages."""
    return [p for p in sys.path if Path(p).name in ("site-packages", "dist-packages") and Path(p).is_dir()]


@pytest.mark.slow
def test_installed_wheel_finds_its_presets(tmp_path):
    dist = tmp_path / "dist"
    build = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-w", str(dist), str(REPO)],
        capture_output=True, text=True,
    )
    assert build.returncode == 0, build.stderr
    wheel = next(dist.glob("clothtool-*.whl"))

    env_dir = tmp_path / "venv"
    venv.EnvBuilder(system_site_packages=False, with_pip=False).create(env_dir)
    python = env_dir / "bin" / "python"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}  # test the wheel, not a checkout
    purelib = subprocess.run(
        [str(python), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
        capture_output=True, text=True, env=env, check=True,
    ).stdout.strip()
    # Plain path lines are appended after the venv's own site-packages (so the wheel's clothtool
    # wins) and their .pth files are not run (so an editable clothtool there stays out).
    (Path(purelib) / "running_environment.pth").write_text("\n".join(running_site_packages()) + "\n")
    install = subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--no-index", str(wheel)],
        capture_output=True, text=True, env=env,
    )
    assert install.returncode == 0, install.stderr

    work = tmp_path / "elsewhere"
    work.mkdir()
    where = subprocess.run(
        [str(python), "-c", "import clothtool.resources as r; print(r.data_dir('presets')); print(r.data_dir('formats'))"],
        capture_output=True, text=True, cwd=work, env=env,
    )
    assert where.returncode == 0, where.stderr
    for line in where.stdout.split():
        assert str(env_dir) in line and "_data" in line  # from the installed wheel, not the checkout

    out = work / "cape.fabric.h5"
    cook = subprocess.run(
        [str(env_dir / "bin" / "clothtool"), "cook", str(EXAMPLES / "cape" / "cape.obj"), "--preset", "coarse",
         "--pin-attr", "color_r", "-o", str(out)],
        capture_output=True, text=True, cwd=work, env=env,
    )
    assert cook.returncode == 0, cook.stderr
    assert out.exists() and "virtual" in cook.stdout  # the coarse preset adds virtual particles
