"""Stress the Gymnasium environment with uniformly random actions: no instability, no NaN, no stray ends.

For every env id and robot, ``--steps`` random steps (split evenly between the two action modes,
``targets`` and ``residual``; actions drawn by ``action_space.sample()`` seeded from ``--seed``),
through ``gymnasium.make`` (so with the registered ``TimeLimit``), resetting after every end. Counted:

* MuJoCo's warnings on the physics (``info["physics_warnings"]``, summed over steps) and every
  MuJoCo warning message logged from any ``MjData`` of the process (MuJoCo reports them through
  the ``absl`` logger: the IK's and the measurements' data included);
* steps whose observation or reward holds a NaN or an infinity, and observations outside the
  observation space;
* episode ends by ``info["termination_reason"]``; a ``TimeLimit`` truncation counts as ``time_limit``;
* exceptions raised by ``step`` or ``reset``.

A run passes when it has no warning, no non-finite or out-of-space step, no exception and every
end is one the environment defines as terminal (the track's end, a failure condition of the task
file, the robot's fall, like Humanoid-v5's unhealthy termination) or the time limit; a
``physics_unstable`` truncation fails it. Falls are reported apart (``ends["fell"]``). The environments are the registered ones with their
defaults, so a failure condition of the task file ends an episode (random actions make the robot
collide with itself within a few steps); ``--run-through-failures`` sets ``terminate_on_failure=False``
so that every episode runs to the end of the track under random actions (a much harder test of the
physics). ``--no-envelope`` switches the target projection off
(:mod:`socialaff_sim.environment.action_limits`) to measure what it prevents. Examples::

    OMP_NUM_THREADS=1 python scripts/env_stress.py --steps 10000 --json stress.json
    OMP_NUM_THREADS=1 python scripts/env_stress.py --ids socialaff_sim/ShakeHands-v0 --robots cmu --steps 2000 --no-envelope

The Unitree robots are used when their MJCF models are found under ``--robots-dir`` (default:
../shared/robots beside the project); otherwise they are skipped with a note.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo is imported (dm_control probes a GL backend)

import argparse  # noqa: E402
import collections  # noqa: E402
import json  # noqa: E402
import logging  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import socialaff_sim  # noqa: E402,F401  (registers the ids)
from socialaff_sim.environment import ENV_IDS  # noqa: E402
from socialaff_sim.environment.episode_end import FAILURE_REASONS  # noqa: E402
from socialaff_sim.errors import SocialAffError  # noqa: E402
from socialaff_sim.retarget.robot import RobotSpec, load_robot  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
UNITREE = {"unitree_h1": ("unitree_h1", "h1.xml"), "unitree_g1": ("unitree_g1", "g1_29dof.xml")}
TASK_ENDS = ("task_complete", "instance_end", *FAILURE_REASONS, "fell", "time_limit")
"""Ends that are the environment's own terminal states (or Gymnasium's time limit); anything else fails a run."""


class _MujocoLog(logging.Handler):
    """Counts MuJoCo's warning messages (``absl`` logger) from any MjData of the process."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: collections.Counter[str] = collections.Counter()

    def emit(self, record: logging.LogRecord) -> None:
        text = record.getMessage()
        if "simulation is unstable" in text or "Nan, Inf" in text or "mj_" in text or "Time =" in text:
            self.messages[text.split(" at ")[0].split(".")[0]] += 1


def robot_spec(name: str, robots_dir: Path) -> str | RobotSpec | None:
    """The robot to pass to the env, ``None`` when a Unitree model is not available."""
    if name not in UNITREE:
        load_robot(name)  # a bad name or mapping file fails here, before any run
        return name
    folder, xml = UNITREE[name]
    path = robots_dir / folder / xml
    return load_robot(name, mjcf=path) if path.exists() else None


def identity_projection(env: Any) -> None:
    """Switch the env's target projection off (targets go to the IK as the box allows them)."""
    env.unwrapped.feasible.project = lambda targets, previous_base, fps: np.array(targets, dtype=np.float64)


def stress(env_id: str, robot: str | RobotSpec, mode: str, steps: int, seed: int, *,
           terminate_on_failure: bool = True, envelope: bool = True) -> dict[str, Any]:
    """Run ``steps`` random steps of ``env_id`` and count what went wrong (see the module docstring)."""
    log = _MujocoLog()
    absl = logging.getLogger("absl")
    absl.addHandler(log)
    env = gym.make(env_id, robot=robot, action_mode=mode, terminate_on_failure=terminate_on_failure)
    if not envelope:
        identity_projection(env)
    space = env.observation_space
    env.action_space.seed(seed)
    rng = np.random.default_rng(seed)
    ends: collections.Counter[str] = collections.Counter()
    warnings: collections.Counter[str] = collections.Counter()
    errors: collections.Counter[str] = collections.Counter()
    bad_values = outside = episodes = n = 0
    cpu = time.process_time()
    try:
        env.reset(seed=int(rng.integers(2**31)))
        while n < steps:
            try:
                obs, reward, term, trunc, info = env.step(env.action_space.sample())
            except Exception as exc:  # noqa: BLE001  (counted and reported: the run fails)
                errors[f"{type(exc).__name__}: {exc}"[:160]] += 1
                env.reset(seed=int(rng.integers(2**31)))
                continue
            n += 1
            warnings.update({k: v for k, v in info["physics_warnings"].items() if v})
            finite = np.isfinite(reward) and all(np.isfinite(v).all() for v in obs.values())
            bad_values += not finite
            outside += finite and not space.contains(obs)
            if term or trunc:
                episodes += 1
                reason = info["termination_reason"]
                ends["time_limit" if reason is None and trunc else str(reason)] += 1
                env.reset(seed=int(rng.integers(2**31)))
    finally:
        env.close()
        absl.removeHandler(log)
    stray = {k: v for k, v in ends.items() if k not in TASK_ENDS}
    return {
        "id": env_id, "robot": robot if isinstance(robot, str) else robot.name, "mode": mode, "steps": n,
        "episodes": episodes, "ends": dict(ends), "physics_warnings": dict(warnings),
        "mujoco_log_warnings": dict(log.messages), "non_finite_steps": bad_values, "outside_space_steps": outside,
        "errors": dict(errors), "cpu_s": round(time.process_time() - cpu, 1),
        "terminate_on_failure": terminate_on_failure, "envelope": envelope,
        "passed": not (warnings or log.messages or bad_values or outside or errors or stray),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ids", nargs="+", default=list(ENV_IDS), help="env ids (default: every namespaced id)")
    ap.add_argument("--robots", nargs="+", default=["ours", "cmu", "unitree_h1", "unitree_g1"])
    ap.add_argument("--modes", nargs="+", default=["targets", "residual"], choices=["targets", "residual"])
    ap.add_argument("--steps", type=int, default=10_000, help="random steps per id and robot, split over the modes")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--robots-dir", type=Path, default=ROOT.parent / "shared" / "robots")
    ap.add_argument("--run-through-failures", action="store_true",
                    help="terminate_on_failure=False: random episodes run to the end of the track")
    ap.add_argument("--no-envelope", action="store_true", help="switch the target projection off")
    ap.add_argument("--json", type=Path, help="write every run's counts here")
    args = ap.parse_args(argv)
    runs, notes = [], []
    per_mode = max(1, args.steps // len(args.modes))
    try:
        robots = {name: robot_spec(name, args.robots_dir) for name in args.robots}
    except SocialAffError as exc:
        print(f"env_stress.py: --robots: {exc}", file=sys.stderr)
        return 2
    for name in args.robots:
        robot = robots[name]
        if robot is None:
            notes.append(f"{name}: skipped, no MJCF under {args.robots_dir}")
            print(notes[-1], flush=True)
            continue
        for env_id in args.ids:
            for k, mode in enumerate(args.modes):
                res = stress(env_id, robot, mode, per_mode, args.seed + k,
                             terminate_on_failure=not args.run_through_failures, envelope=not args.no_envelope)
                runs.append(res)
                print(json.dumps(res), flush=True)
                if args.json:  # after every run, so that an interrupted sweep keeps what it measured
                    _write(args.json, argv, notes, runs)
    total = _write(args.json, argv, notes, runs) if args.json else _total(runs)
    print(json.dumps(total), flush=True)
    return 0 if not total["failed_runs"] else 1


def _total(runs: list[dict[str, Any]]) -> dict[str, Any]:
    return {
        "runs": len(runs), "steps": sum(r["steps"] for r in runs), "episodes": sum(r["episodes"] for r in runs),
        "failed_runs": [f"{r['id']} {r['robot']} {r['mode']}" for r in runs if not r["passed"]],
        "physics_warnings": sum(sum(r["physics_warnings"].values()) for r in runs),
        "mujoco_log_warnings": sum(sum(r["mujoco_log_warnings"].values()) for r in runs),
        "non_finite_steps": sum(r["non_finite_steps"] for r in runs), "errors": sum(sum(r["errors"].values()) for r in runs),
    }


def _write(path: Path, argv: list[str] | None, notes: list[str], runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Write the runs so far, with the command, the machine and the load, to ``path``; returns the totals."""
    total = _total(runs)
    meta = {"command": " ".join(["python", "scripts/env_stress.py", *(argv if argv is not None else sys.argv[1:])]),
            "machine": f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}",
            "load_average": os.getloadavg(), "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())}
    path.write_text(json.dumps({"meta": meta, "notes": notes, "total": total, "runs": runs}, indent=1))
    return total


if __name__ == "__main__":
    sys.exit(main())
