"""Gymnasium ids: namespaced and legacy ids registered on ``import socialaff_sim``, usable from a fresh interpreter."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym

import socialaff_sim  # noqa: F401  (registers the ids)
from socialaff_sim.environment.config import CONTROL_DT, EnvConfig
from socialaff_sim.gym_ids import ENV_IDS, LEGACY_IDS, MAX_EPISODE_SECONDS, MAX_EPISODE_STEPS, NAMESPACE, register_envs

ROOT = Path(__file__).resolve().parents[1]


def _fresh(code: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    """Run ``code`` in a new interpreter that imports this checkout, warnings as errors."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    env.pop("MUJOCO_GL", None)
    return subprocess.run([sys.executable, "-W", "error", "-c", code], capture_output=True, text=True, env=env, cwd=cwd)


def test_namespaced_and_legacy_ids_name_the_same_environments() -> None:
    assert set(ENV_IDS) <= set(gym.registry) and set(LEGACY_IDS) <= set(gym.registry)
    for env_id, label in ENV_IDS.items():
        spec = gym.spec(env_id)
        assert spec.namespace == NAMESPACE and spec.max_episode_steps == MAX_EPISODE_STEPS
        assert spec.kwargs.get("interactions") == label
    for old, new in LEGACY_IDS.items():
        assert gym.spec(old).namespace is None
        assert gym.spec(old).kwargs == gym.spec(new).kwargs and gym.spec(old).entry_point == gym.spec(new).entry_point
    assert {ENV_IDS[n] for n in LEGACY_IDS.values()} == set(ENV_IDS.values())
    register_envs()  # idempotent: re-registering must not warn (warnings are errors)


def test_ids_exist_after_importing_any_part_of_the_package(tmp_path: Path) -> None:
    code = (
        "import sys, gymnasium as gym\n"
        "import socialaff_sim.data\n"
        "assert 'socialaff_sim.environment' not in sys.modules and 'mujoco' not in sys.modules\n"
        "print(gym.spec('socialaff_sim/ShakeHands-v0').kwargs['interactions'])\n"
    )
    out = _fresh(code, tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["shake_hands"]


def test_make_without_importing_the_package(tmp_path: Path) -> None:
    """Gymnasium imports the module named before the colon; nothing of ours is imported by hand."""
    code = (
        "import gymnasium as gym\n"
        "env = gym.make('socialaff_sim:socialaff_sim/HighFive-v0', max_frames=4)\n"
        "obs, info = env.reset(seed=0)\n"
        "print(env.spec.id, info['interaction'])\n"
        "env.close()\n"
    )
    out = _fresh(code, tmp_path)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["socialaff_sim/HighFive-v0", "high_five"]


def test_time_limit_in_seconds_matches_the_default_control_period() -> None:
    """The registered TimeLimit counts control steps: MAX_EPISODE_STEPS of the default period make the time
    limit in seconds (the ids would otherwise cut episodes at another length when the period changes)."""
    assert EnvConfig().control_dt == CONTROL_DT
    assert abs(MAX_EPISODE_STEPS * CONTROL_DT - MAX_EPISODE_SECONDS) < 1e-9
    assert MAX_EPISODE_SECONDS >= 7.0  # longer than every synthetic instance (duration_range up to 7 s)
