"""The one-way layers of pyproject.toml's ``[tool.importlinter]`` hold (``lint-imports``, run here because CI runs pytest).

The contracts are checked on this checkout's ``socialaff_sim`` (not an installed copy), and, so that the
check is known to be able to fail, on a copy of the package with one upward import and one cycle added.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("importlinter", reason="the layer check needs import-linter (pip install -e '.[test]')")

ROOT = Path(__file__).resolve().parents[1]
_RUN = "import sys; from importlinter.cli import lint_imports; sys.exit(lint_imports(no_cache=True, no_logo=True))"


def _lint(cwd: Path) -> subprocess.CompletedProcess[str]:
    """Run lint-imports with ``cwd``'s pyproject.toml on ``cwd``'s socialaff_sim package."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(cwd), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-c", _RUN], cwd=cwd, env=env, capture_output=True, text=True, check=False)


def test_the_package_keeps_its_layers_and_has_no_cycles() -> None:
    res = _lint(ROOT)
    assert res.returncode == 0, res.stdout + res.stderr
    assert "2 kept, 0 broken" in res.stdout


def test_an_upward_import_and_a_cycle_break_the_contracts(tmp_path: Path) -> None:
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    pkg = tmp_path / "socialaff_sim"
    shutil.copytree(ROOT / "socialaff_sim", pkg, ignore=shutil.ignore_patterns("__pycache__"))
    # data (a low layer) importing the learner is an upward import ...
    with open(pkg / "data" / "summary.py", "a", encoding="utf-8") as fh:
        fh.write("\nfrom ..learning import estimator as _upward  # noqa: E402\n")
    # ... and two modules of one package importing each other is a cycle, even inside a function.
    with open(pkg / "sim" / "scene_human.py", "a", encoding="utf-8") as fh:
        fh.write("\n\ndef _cycle() -> object:\n    from . import scene\n\n    return scene\n")
    res = _lint(tmp_path)
    assert res.returncode == 1, res.stdout + res.stderr
    assert "0 kept, 2 broken" in res.stdout
    assert "socialaff_sim.data is not allowed to import socialaff_sim.learning" in res.stdout
    assert "socialaff_sim.data.summary -> socialaff_sim.learning.estimator" in res.stdout
    assert "No cycles are allowed in socialaff_sim.sim" in res.stdout
