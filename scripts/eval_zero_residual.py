"""Play the affordance model alone (the zero residual) on the RL example's held-out episodes; no training.

The same data, split, models and episodes as ``scripts/train_residual.py``'s held-out evaluation (one episode
per held-out instance, the k-th with reset seed 10000 + 1000·seed + k), so its zero-residual rows can be
compared with a recorded run's after a change of the environment. ``--train`` plays the training instances
instead, with the seeds and the training reward of ``train_residual.py --reference-only``. Writes
``zero_residual.json`` (rows and, per label, success and termination reasons) into ``--out``. Example::

    OMP_NUM_THREADS=1 nice -n 10 python scripts/eval_zero_residual.py --out zr --models rl_real_ref/models \\
        --data handover:../shared/data/handover_h2h sbu:../shared/data/sbu_kinect_interaction \\
        nuisi:../shared/data/nuisi_v1 --interactions hand_over shaking_hands handshake

Needs the ``[rl]`` extra (it reuses ``train_residual.py``). The library never imports this script.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402

from socialaff_sim._atomic import atomic_write_text  # noqa: E402
from socialaff_sim.learning import SocialAffordanceModel  # noqa: E402

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:
    sys.path.append(_HERE)
from _residual_episodes import held_out_episodes, run_episodes, training_episodes, zero_policy  # noqa: E402
from train_residual import Settings, build_data, make_env  # noqa: E402


def main() -> None:
    d = Settings()
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--models", type=Path, required=True, help="<interaction>.npz of the run compared with")
    ap.add_argument("--interactions", nargs="+", default=list(d.labels))
    ap.add_argument("--data", nargs="+", default=list(d.data), metavar="SPEC")
    ap.add_argument("--seed", type=int, default=d.seed)
    ap.add_argument("--robot", default=d.robot)
    ap.add_argument("--train-affordance-weight", type=float, default=d.train_affordance_weight)
    ap.add_argument("--train", action="store_true", help="the training instances (reference-only's episodes)")
    a = ap.parse_args()
    s = Settings(labels=tuple(a.interactions), data=tuple(a.data), seed=a.seed, robot=a.robot,
                 train_affordance_weight=a.train_affordance_weight)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    train_set, held_out = build_data(s)
    models = {lbl: SocialAffordanceModel.load(a.models / f"{lbl}.npz") for lbl in s.labels}
    if a.train:
        env = make_env(s, train_set, models, training=True)
        episodes = training_episodes([i.instance_id for i in train_set], s.seed)
    else:
        env = make_env(s, held_out, models)
        episodes = held_out_episodes([i.instance_id for i in held_out], s.seed)
    rows = run_episodes(env, episodes, zero_policy(env))
    per_label = {}
    for lbl in s.labels:
        mine = [r for r in rows if r["interaction"] == lbl]
        per_label[lbl] = {"episodes": len(mine), "success": sum(r["success"] for r in mine),
                          "reasons": dict(Counter(r["termination_reason"] or "instance_end" for r in mine)),
                          "self_collision_on_step_1": sum(r["termination_reason"] == "self_collision"
                                                          and r["steps"] == 1 for r in mine)}
        print(f"{lbl:14s} {per_label[lbl]}", flush=True)
    total = sum(p["success"] for p in per_label.values())
    print(f"all: {total}/{len(rows)} successes; wall {time.perf_counter() - wall0:.0f} s, "
          f"CPU {time.process_time() - cpu0:.0f} s")
    a.out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(a.out / "zero_residual.json", json.dumps(
        {"settings": {k: str(v) for k, v in vars(a).items()}, "per_label": per_label, "episodes": rows,
         "wall_s": time.perf_counter() - wall0, "cpu_s": time.process_time() - cpu0}, indent=1))


if __name__ == "__main__":
    main()
