"""Benchmark the Gymnasium environment: env steps per second in one process, without rendering.

Runs whole episodes of ``SocialAffordanceEnv`` on the synthetic dataset with a
fixed policy and reports steps per second of CPU time (``time.process_time``,
what "one core" means on a shared machine) and of wall time, with and without
the resets, and the sub-goal success and failure rates of the finished episodes
(with ``proposal``: how well the physics preset replays the recorded agent 1). Policies:

* ``proposal``: ``residual`` actions of zero (the robot tracks the adapter's proposal,
  the ground-truth recording by default): the typical per-step cost;
* ``random-residual``: uniform residuals;
* ``random-targets``: uniform ``targets`` actions (episodes end early on failures, so
  resets weigh more).

``--profile`` adds a cProfile breakdown of where the time goes. Run with
OMP_NUM_THREADS=1, e.g.::

    OMP_NUM_THREADS=1 python scripts/bench_env.py --steps 3000
    OMP_NUM_THREADS=1 python scripts/bench_env.py --physics accurate --steps 2000
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo is imported (dm_control probes a GL backend)

import argparse  # noqa: E402
import cProfile  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import pstats  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset  # noqa: E402
from socialaff_sim.environment import SocialAffordanceEnv  # noqa: E402


def run(env: SocialAffordanceEnv, policy: str, n_steps: int, rng: np.random.Generator) -> dict[str, float]:
    """Step ``env`` for ``n_steps`` (whole episodes, the last one cut) and time it."""
    cpu_step = cpu_reset = wall_step = wall_reset = 0.0
    steps = episodes = 0
    finished: list[dict[str, bool]] = []
    env.action_space.seed(int(rng.integers(1 << 31)))
    zero = np.zeros(env.action_space.shape, np.float32)
    while steps < n_steps:
        c, w = time.process_time(), time.perf_counter()
        env.reset(seed=int(rng.integers(1 << 31)))
        cpu_reset += time.process_time() - c
        wall_reset += time.perf_counter() - w
        episodes += 1
        done = False
        while not done and steps < n_steps:
            a = zero if policy == "proposal" else env.action_space.sample()
            c, w = time.process_time(), time.perf_counter()
            _, _, term, trunc, info = env.step(a)
            cpu_step += time.process_time() - c
            wall_step += time.perf_counter() - w
            steps += 1
            done = term or trunc
        if done:
            finished.append({"success": info["success"], "failed": info["failed"]})
    return {
        "steps": steps,
        "episodes": episodes,
        "cpu_steps_per_s": steps / cpu_step,
        "cpu_steps_per_s_with_resets": steps / (cpu_step + cpu_reset),
        "wall_steps_per_s": steps / wall_step,
        "wall_steps_per_s_with_resets": steps / (wall_step + wall_reset),
        "cpu_ms_per_reset": 1e3 * cpu_reset / episodes,
        "episodes_finished": len(finished),
        "success_rate": float(np.mean([f["success"] for f in finished])) if finished else float("nan"),
        "failure_rate": float(np.mean([f["failed"] for f in finished])) if finished else float("nan"),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", default="ours", help="ours | cmu | mapping .toml")
    ap.add_argument("--physics", default="fast", choices=["fast", "accurate"])
    ap.add_argument("--policy", default="proposal", choices=["proposal", "random-residual", "random-targets"])
    ap.add_argument("--interactions", nargs="*", default=None, help="labels (default: all five)")
    ap.add_argument("--steps", type=int, default=3000, help="env steps to time")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--profile", action="store_true", help="print the 25 most expensive functions")
    ap.add_argument("--json", default=None, help="also write the result here")
    args = ap.parse_args()

    data = generate_dataset(seed=args.seed, config=SyntheticConfig(instances_per_interaction=8))
    mode = "targets" if args.policy == "random-targets" else "residual"
    env = SocialAffordanceEnv(interactions=args.interactions, data=data, robot=args.robot, action_mode=mode,
                              physics=args.physics)
    rng = np.random.default_rng(args.seed)
    run(env, args.policy, 100, rng)  # warm-up: every scene compiled once
    prof = cProfile.Profile() if args.profile else None
    if prof is not None:
        prof.enable()
    res = run(env, args.policy, args.steps, rng)
    if prof is not None:
        prof.disable()
    res.update(robot=args.robot, physics=args.physics, policy=args.policy,
               interactions=list(env.pool.labels))
    print(json.dumps(res, indent=2))
    if prof is not None:
        out = io.StringIO()
        pstats.Stats(prof, stream=out).sort_stats("tottime").print_stats(25)
        print(out.getvalue())
    if args.json:
        from socialaff_sim._atomic import atomic_write_text

        atomic_write_text(args.json, json.dumps(res, indent=2))


if __name__ == "__main__":
    main()
