"""The wheel ships presets/ and formats/: build it, install it into a fresh venv, and cook
with a bundled preset from a directory outside the source tree."""

from __future__ import annotations

import subprocess
import sys
import venv

import pytest

from tests.conftest import EXAMPLES, REPO


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
    # system site packages provide the dependencies (no network needed); the wheel provides clothtool
    venv.EnvBuilder(system_site_packages=True, with_pip=False).create(env_dir)
    python = env_dir / "bin" / "python"
    install = subprocess.run(
        [sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps", "--force-reinstall", str(wheel)],
        capture_output=True, text=True,
    )
    assert install.returncode == 0, install.stderr

    work = tmp_path / "elsewhere"
    work.mkdir()
    where = subprocess.run(
        [str(python), "-c", "import clothtool.resources as r; print(r.data_dir('presets')); print(r.data_dir('formats'))"],
        capture_output=True, text=True, cwd=work,
    )
    assert where.returncode == 0, where.stderr
    for line in where.stdout.split():
        assert str(env_dir) in line and "_data" in line  # from the installed wheel, not the checkout

    out = work / "cape.fabric.h5"
    cook = subprocess.run(
        [str(env_dir / "bin" / "clothtool"), "cook", str(EXAMPLES / "cape" / "cape.obj"), "--preset", "coarse",
         "--pin-attr", "color_r", "-o", str(out)],
        capture_output=True, text=True, cwd=work,
    )
    assert cook.returncode == 0, cook.stderr
    assert out.exists() and "virtual" in cook.stdout  # the coarse preset adds virtual particles
