"""What a speed option of the environment costs in fidelity: the recorded agent 1 replayed through the env.

The default env (``socialaff_sim/SocialAffordance-v0``, synthetic data, ground-truth adapter) in ``residual``
mode with zero residuals, i.e. the robot follows the recorded agent 1, over the first ``--per-label``
instances of every interaction, once per setting given. Each setting is the ``--physics`` preset with
some :class:`~socialaff_sim.sim.simulator.SimConfig` fields replaced (``--settings``: semicolon-separated
lists of ``field=value``; ``ik.iterations`` reaches into the IK's settings). Reported per setting:

* sub-goal success per interaction (every sub-goal met, no failure) and how the episodes ended;
* the wrists' and ankles' IK accuracy: the fraction of reachable key-frame targets within 2 cm
  (``socialaff_sim.sim.episode.ERROR_OK``), and the 95th percentile of their error;
* the force on the person (the scorer's smoothed total, N): median and largest episode maximum;
* the support figures (docs/environment.md): mean share of the weight carried by the harness, largest
  trunk tilt, foot sliding per episode;
* MuJoCo warnings; physics steps per frame; CPU steps per second of this replay (one core, so only
  comparable between the settings of one run).

Example::

    OMP_NUM_THREADS=1 python scripts/bench_env_fidelity.py --per-label 8 \\
        --settings "" "compliant_person=False" "timestep=0.012" "ik.iterations=2" --json fidelity.json
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import json
import time
from typing import Any

import gymnasium as gym
import numpy as np

import socialaff_sim  # noqa: F401  (registers the ids)
from socialaff_sim._atomic import atomic_write_text
from socialaff_sim.environment import physics_config
from socialaff_sim.sim.episode import ERROR_OK
from socialaff_sim.sim.simulator import SimConfig

ENV_ID = "socialaff_sim/SocialAffordance-v0"


def parse_setting(text: str, physics: str) -> SimConfig:
    """The preset's settings with ``field=value`` pairs (``;``-separated) replaced."""
    cfg = physics_config(physics)
    for item in filter(None, (t.strip() for t in text.split(";"))):
        name, _, value = item.partition("=")
        v = ast.literal_eval(value.strip())
        if name.strip() == "ik.iterations":
            cfg = dataclasses.replace(cfg, ik=dataclasses.replace(cfg.ik, iterations=int(v)))
        else:
            cfg = dataclasses.replace(cfg, **{name.strip(): v})
    return cfg


def replay(cfg: SimConfig, physics: str, per_label: int, robot: str) -> dict[str, Any]:
    # One env step per data frame (the per-frame figures below; a held action gives the same physics either way).
    env = gym.make(ENV_ID, action_mode="residual", robot=robot, physics=physics, sim_config=cfg, control_dt=None)
    u = env.unwrapped
    zero = np.zeros(env.action_space.shape, env.action_space.dtype)
    success: dict[str, list[bool]] = {}
    ends: dict[str, int] = {}
    errors: list[np.ndarray] = []
    force, harness, tilt, slide, substeps = [], [], [], [], []
    warnings = steps = 0
    cpu = 0.0
    for label in u.pool.labels:
        for inter in [i for i in u.pool.instances if i.label == label][:per_label]:
            env.reset(seed=0, options={"instance": inter.instance_id})
            sim = u.simulator
            c = time.process_time()
            while True:
                _, _, term, trunc, info = env.step(zero)
                steps += 1
                warnings += sum(info["physics_warnings"].values())
                if term or trunc:
                    break
            cpu += time.process_time() - c
            res = sim.results
            err = np.array([r.ik_error for r in res])
            reach = np.array([r.reachable for r in res]) & np.broadcast_to(inter.key_available(), err.shape)
            errors.append(err[reach])
            success.setdefault(label, []).append(bool(info.get("success", False)))
            reason = str(info.get("termination_reason"))
            ends[reason] = ends.get(reason, 0) + 1
            force.append(sim.scorer.max_force_filtered)
            sup = [r.support for r in res if r.support is not None]
            harness.append(float(np.mean([s.outside_mean for s in sup])) if sup else float("nan"))
            tilt.append(max((s.tilt_deg for s in sup), default=float("nan")))
            slide.append(float(sum(s.slide for s in sup)))
            substeps.append(sim.n_sub)
    env.close()
    err = np.concatenate(errors)
    total = sum(sum(v) for v in success.values())
    n = sum(len(v) for v in success.values())
    return {
        "success": {k: f"{sum(v)}/{len(v)}" for k, v in success.items()}, "success_total": f"{total}/{n}",
        "ends": ends, "key_targets_within_2cm": float((err <= ERROR_OK).mean()),
        "key_error_p95_m": float(np.percentile(err, 95)),
        "force_on_person_max_N": {"median": float(np.median(force)), "max": float(np.max(force))},
        "harness_share_mean": float(np.nanmean(harness)), "tilt_max_deg": float(np.nanmax(tilt)),
        "foot_slide_m_per_episode": float(np.mean(slide)), "mujoco_warnings": int(warnings),
        "physics_steps_per_frame": float(np.mean(substeps)), "steps": steps,
        "steps_per_s_cpu": steps / cpu,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--settings", nargs="+", default=[""], help='e.g. "" "compliant_person=False;timestep=0.012"')
    ap.add_argument("--physics", default="fast", choices=["fast", "accurate"])
    ap.add_argument("--per-label", type=int, default=8, help="instances per interaction")
    ap.add_argument("--robot", default="ours")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    out = {}
    for text in args.settings:
        out[text or "(preset)"] = replay(parse_setting(text, args.physics), args.physics, args.per_label, args.robot)
        print(json.dumps({text or "(preset)": out[text or "(preset)"]}), flush=True)
    if args.json:
        atomic_write_text(args.json, json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
