"""MuJoCo's GL backend is chosen on import: the user's MUJOCO_GL, a display's GLFW, else EGL, else OSMesa."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from socialaff_sim._headless import choose_gl_backend

ROOT = Path(__file__).resolve().parents[1]


def _libs(*present: str):
    return lambda name: f"lib{name}.so.1" if name in present else None


def test_user_choice_wins() -> None:
    env = {"MUJOCO_GL": "osmesa"}
    choice = choose_gl_backend(env, _libs("EGL"), mujoco_imported=False)
    assert choice.backend == "osmesa" and env == {"MUJOCO_GL": "osmesa"} and "set by the user" in choice.reason


@pytest.mark.parametrize("display", ["DISPLAY", "WAYLAND_DISPLAY"])
def test_display_leaves_the_default(display: str) -> None:
    env = {display: ":0"}
    choice = choose_gl_backend(env, _libs("EGL", "OSMesa"), mujoco_imported=False)
    assert choice.backend is None and "MUJOCO_GL" not in env


@pytest.mark.parametrize(("libs", "expected"), [(("EGL", "OSMesa"), "egl"), (("OSMesa",), "osmesa"), ((), "egl")])
def test_headless_prefers_egl_then_osmesa(libs: tuple[str, ...], expected: str) -> None:
    env: dict[str, str] = {}
    choice = choose_gl_backend(env, _libs(*libs), mujoco_imported=False)
    assert choice.backend == expected and env["MUJOCO_GL"] == expected
    assert ("install libegl1" in choice.reason) == (not libs)


def test_late_choice_is_reported() -> None:
    choice = choose_gl_backend({}, _libs("EGL"), mujoco_imported=True)
    assert "imported earlier" in choice.reason


def test_fresh_interpreter_without_display_warns_nothing(tmp_path: Path) -> None:
    """No GLFW warning: the package sets MUJOCO_GL before dm_control and MuJoCo are imported."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL")}
    env["PYTHONPATH"] = str(ROOT)
    code = "import os, socialaff_sim, dm_control.mujoco\nprint(os.environ.get('MUJOCO_GL'))\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "GLFW" not in out.stderr, out.stderr
    assert out.stdout.strip() in ("egl", "osmesa")


def test_verbose_cli_says_which(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY", "MUJOCO_GL")}
    env["PYTHONPATH"] = str(ROOT)
    out = subprocess.run([sys.executable, "-m", "socialaff_sim.cli.main", "data", "synth", "--verbose"],
                         capture_output=True, text=True, env=env, cwd=tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    assert "rendering: MUJOCO_GL=" in out.stderr
    quiet = subprocess.run([sys.executable, "-m", "socialaff_sim.cli.main", "data", "synth"],
                           capture_output=True, text=True, env=env, cwd=tmp_path)
    assert "rendering:" not in quiet.stderr
