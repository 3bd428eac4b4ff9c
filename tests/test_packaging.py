"""A plain (non-editable) wheel install finds its assets and task files; CI runs the README's test command."""

from __future__ import annotations

import json
import os
import site
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

_PROBE = r"""
import json, sys, tomllib
from pathlib import Path
import mujoco
import socialaff_sim
from socialaff_sim import resources
assets = resources.assets_dir()
envs = resources.envs_dir()
xmls = sorted(p for p in assets.rglob("*.xml"))
tomls = sorted(envs.glob("*.toml"))
model = mujoco.MjModel.from_xml_path(str(xmls[0]))
task = tomllib.loads(tomls[0].read_text())
print(json.dumps({
    "package": socialaff_sim.__file__,
    "assets": sorted(str(p.relative_to(assets)) for p in assets.rglob("*") if p.is_file()),
    "envs": sorted(str(p.relative_to(envs)) for p in envs.rglob("*") if p.is_file()),
    "nbody": model.nbody,
    "task_keys": sorted(task),
}))
"""


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file() and "__pycache__" not in p.parts)


def _dependency_dirs() -> list[str]:
    """The running interpreter's site-packages folders (where mujoco & co. are installed), whatever kind of
    environment it is: a venv, a conda env, Debian's system Python (dist-packages) or a user site."""
    dirs = list(site.getsitepackages())
    if site.ENABLE_USER_SITE:
        dirs.append(site.getusersitepackages())
    return [d for d in dict.fromkeys(dirs) if Path(d).is_dir()]


def test_wheel_in_fresh_venv_ships_assets_and_envs(tmp_path: Path) -> None:
    wheel_dir = tmp_path / "wheel"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(wheel_dir), str(ROOT)],
        check=True,
        capture_output=True,
    )
    wheels = list(wheel_dir.glob("socialaff_sim-*.whl"))
    assert len(wheels) == 1, wheels
    venv = tmp_path / "venv"
    # A bare venv sees the dependencies (mujoco, ...) through a .pth listing the running interpreter's
    # site-packages: --system-site-packages would point at the *base* interpreter, which inside a venv
    # lacks them. Plain path entries: .pth files there (e.g. an editable install of this package) are not run.
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    py = venv / "bin" / "python"
    purelib = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                             check=True, capture_output=True, text=True).stdout.strip()
    (Path(purelib) / "_outer_dependencies.pth").write_text("\n".join(_dependency_dirs()) + "\n")
    subprocess.run([sys.executable, "-m", "pip", "--python", str(py), "install", "--no-deps", "-q", str(wheels[0])],
                   check=True, capture_output=True)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    out = subprocess.run(
        [str(py), "-c", _PROBE], check=True, capture_output=True, text=True, cwd=tmp_path, env=env
    ).stdout
    info = json.loads(out.strip().splitlines()[-1])
    assert Path(info["package"]).is_relative_to(venv), info["package"]
    assert info["assets"] == _files(ROOT / "assets")
    assert info["envs"] == _files(ROOT / "envs")
    assert info["nbody"] > 1
    assert info["task_keys"]


def test_ci_runs_exactly_the_readme_test_command() -> None:
    readme = (ROOT / "README.md").read_text()
    ci = (ROOT / ".ci" / "run").read_text()
    blocks = [b.split("```", 1)[0].strip() for b in readme.split("```bash")[1:]]
    test_cmds = [b for b in blocks if "pytest" in b]
    assert test_cmds, "README.md has no test command in a ```bash block"
    assert test_cmds[0] in ci


def test_pyproject_declares_the_design_card_packages() -> None:
    meta = tomllib.loads((ROOT / "pyproject.toml").read_text())
    deps = " ".join(meta["project"]["dependencies"]).lower()
    for name in ("mujoco", "dm-control", "numpy", "scipy", "mink", "gymnasium", "daqp"):
        assert name in deps, name
    assert meta["project"]["scripts"]["socialaff-sim"] == "socialaff_sim.cli.main:main"


@pytest.mark.parametrize("folder", ["assets", "envs", "socialaff_sim", "tests", "scripts"])
def test_design_card_layout(folder: str) -> None:
    assert (ROOT / folder).is_dir()
    assert (ROOT / "socialaff_sim" / "py.typed").is_file()
