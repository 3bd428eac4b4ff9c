"""Roll out policies in the Gymnasium environment: random vs the affordance model's own synthesis.

For each interaction of the synthetic dataset, the instances are split into
pair-disjoint train and test parts; a model is fitted on the train part (or
loaded from ``--models DIR/<interaction>.npz``) and every policy plays the test
instances:

* ``random``: uniform ``targets`` actions (the action space's own sampler);
* ``synthesis``: zero ``residual`` actions with the model adapter, i.e. the robot
  follows the model's online synthesis (Algorithm 2) of agent 1;
* ``gt-proposal`` (an oracle, for reference): zero ``residual`` actions with the
  ground-truth adapter, i.e. the robot replays the recorded agent 1.

``random`` and ``synthesis`` are scored with the same reward (the model's
affordance term plus the task's sub-goal terms); ``gt-proposal`` is scored with
the ground-truth adapter's Gaussian proxy instead, so compare it on
``subgoal_return`` (the sub-goal terms only) and the success rate. Without
``--models``/``--fit`` the ``synthesis`` row is left out and ``random`` uses the
ground-truth adapter's reward. Example::

    OMP_NUM_THREADS=1 python scripts/rollout.py --fit --episodes 6 --json rollout.json
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo is imported (dm_control probes a GL backend)

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
import zlib  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from socialaff_sim._atomic import atomic_write_text  # noqa: E402
from socialaff_sim.data.dataset import actor_disjoint_folds  # noqa: E402
from socialaff_sim.data.synthetic import generate_dataset  # noqa: E402
from socialaff_sim.environment import SocialAffordanceEnv  # noqa: E402
from socialaff_sim.learning.config import LearningConfig  # noqa: E402
from socialaff_sim.learning import SocialAffordanceModel  # noqa: E402


def play(env: SocialAffordanceEnv, instances: list[str], policy: str, seed: int) -> dict[str, object]:
    """Mean return, success rates and failure rate of ``policy`` over one episode per instance."""
    env.action_space.seed(seed)
    zero = np.zeros(env.action_space.shape, np.float32)
    returns, subgoal_returns, successes, failures, steps = [], [], [], [], 0
    per_subgoal: dict[str, list[bool]] = {}
    for k, inst in enumerate(instances):
        env.reset(seed=seed + k, options={"instance": inst})
        total = sub = 0.0
        while True:
            action = env.action_space.sample() if policy == "random" else zero
            _, reward, term, trunc, info = env.step(action)
            steps += 1
            total += reward
            sub += reward - info["reward_affordance"]
            if term or trunc:
                break
        returns.append(total)
        subgoal_returns.append(sub)
        successes.append(info["success"])
        failures.append(info["failed"])
        for name, ok in info["subgoals"].items():
            per_subgoal.setdefault(name, []).append(ok)
    return {
        "episodes": len(instances),
        "steps": steps,
        "mean_return": float(np.mean(returns)),
        "mean_subgoal_return": float(np.mean(subgoal_returns)),
        "success_rate": float(np.mean(successes)),
        "subgoal_success": {k: float(np.mean(v)) for k, v in per_subgoal.items()},
        "failure_rate": float(np.mean(failures)),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--interactions", nargs="*", default=None, help="labels (default: all five)")
    ap.add_argument("--episodes", type=int, default=6, help="test episodes per interaction and policy")
    ap.add_argument("--robot", default="ours")
    ap.add_argument("--physics", default="fast", choices=["fast", "accurate"])
    ap.add_argument("--seed", type=int, default=0, help="dataset, split, fitting and policy seed")
    src = ap.add_mutually_exclusive_group()
    src.add_argument("--models", type=Path, default=None, help="folder of fitted models <interaction>.npz")
    src.add_argument("--fit", action="store_true", help="fit the models on the train split first")
    ap.add_argument("--fit-iterations", type=int, default=LearningConfig().iterations, help="Algorithm 1 iterations")
    ap.add_argument("--save-models", type=Path, default=None, help="with --fit: also save the models here")
    ap.add_argument("--json", type=Path, default=None, help="also write the results here")
    args = ap.parse_args()

    data = generate_dataset(seed=args.seed)
    labels = args.interactions or list(data.labels)
    results: dict[str, dict[str, object]] = {}
    for label in labels:
        rng = np.random.default_rng([args.seed, zlib.crc32(label.encode())])  # per label: runs can be split
        inters = list(data.of_label(label))
        train_idx, test_idx = actor_disjoint_folds(inters, 4, rng=rng)[0]
        test = [inters[i].instance_id for i in test_idx[: args.episodes]]
        model = None
        if args.models is not None:
            model = SocialAffordanceModel.load(args.models / f"{label}.npz")
        elif args.fit:
            tic = time.process_time()
            learning = LearningConfig(iterations=args.fit_iterations)
            model = SocialAffordanceModel(learning=learning).fit([inters[i] for i in train_idx], rng=rng)
            print(f"{label}: fitted on {len(train_idx)} instances in {time.process_time() - tic:.0f} s CPU", flush=True)
            if args.save_models is not None:
                model.save(args.save_models / f"{label}.npz")
        # One env step per data frame (control_dt=None), as docs/environment.md's "Policies" table was measured.
        common = {"interactions": label, "data": inters, "robot": args.robot, "physics": args.physics, "control_dt": None}
        rows: dict[str, object] = {}
        scored = {"model": {label: model}} if model is not None else {}
        rows["random"] = play(SocialAffordanceEnv(action_mode="targets", **scored, **common), test, "random", args.seed)
        if model is not None:
            rows["synthesis"] = play(SocialAffordanceEnv(action_mode="residual", **scored, **common), test, "zero", args.seed)
        rows["gt-proposal"] = play(SocialAffordanceEnv(action_mode="residual", **common), test, "zero", args.seed)
        results[label] = rows
        for name, r in rows.items():
            print(f"{label:12s} {name:12s} return {r['mean_return']:8.1f}  sub-goal return {r['mean_subgoal_return']:6.1f}  "
                  f"success {r['success_rate']:.2f}  failures {r['failure_rate']:.2f}", flush=True)

    policies = sorted({p for rows in results.values() for p in rows}, key=["random", "synthesis", "gt-proposal"].index)
    print("\n| interaction | " + " | ".join(f"{p} return | {p} success" for p in policies) + " |")
    print("|---" * (1 + 2 * len(policies)) + "|")
    for label, rows in results.items():
        cells = []
        for p in policies:
            r = rows.get(p)
            cells += ["–", "–"] if r is None else [f"{r['mean_return']:.1f}", f"{r['success_rate']:.2f}"]
        print(f"| {label} | " + " | ".join(cells) + " |")
    if args.json is not None:
        atomic_write_text(args.json, json.dumps({"seed": args.seed, "robot": args.robot, "physics": args.physics,
                                                 "results": results}, indent=2))


if __name__ == "__main__":
    main()
