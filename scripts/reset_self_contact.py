"""Count the episodes whose robot starts in self-contact: at reset and after the first environment step.

For every instance of the given recorded data sets whose label has a task, per robot, the environment
(residual mode, zero residual) is reset onto the instance and stepped once (one control period); after the
reset's settle and after that step, every pair of robot geoms MuJoCo finds interpenetrating is listed.
A pair is a *legs* pair when each geom hangs from a different leg (the subtrees of the robot's left and
right hip limb roots: thighs, shins, feet). Reported per (data set, label, robot): episodes, those with any
robot self-penetration at reset, with a legs pair at reset, deeper than the task's self-collision threshold
(2 cm) at reset, and those ending with ``self_collision`` on step 1. ``--replay`` plays each episode on to its
end (the zero residual: the source's proposal alone) and adds the success rate and the termination reasons.

The source is the recording itself (the ground-truth adapter: agent 1's recorded key joints retargeted onto
the robot), or with ``--models DIR`` the affordance models ``DIR/<label>.npz`` (the causal synthesis, as the
RL example plays it). Example::

    OMP_NUM_THREADS=1 python scripts/reset_self_contact.py --robots ours unitree_h1 \\
        --mjcf unitree_h1=../shared/robots/unitree_h1/h1.xml --json reset_contacts.json

The library never imports this script.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from collections import Counter  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from socialaff_sim._atomic import atomic_write_text  # noqa: E402
from socialaff_sim.data.specs import load_dataset  # noqa: E402
from socialaff_sim.environment import SocialAffordanceEnv  # noqa: E402
from socialaff_sim.errors import ConfigError  # noqa: E402
from socialaff_sim.learning import SocialAffordanceModel  # noqa: E402
from socialaff_sim.retarget.kinematic_tree import subtree_mask  # noqa: E402
from socialaff_sim.retarget.robot import load_robot  # noqa: E402
from socialaff_sim.sim.tasks import task_for_label  # noqa: E402

_SHARED = Path(__file__).resolve().parents[1].parent / "shared"
DATA = (f"handover:{_SHARED / 'data/handover_h2h'}", f"sbu:{_SHARED / 'data/sbu_kinect_interaction'}",
        f"nuisi:{_SHARED / 'data/nuisi_v1'}")
THRESHOLD = 0.02
"""m: the tasks' self-collision threshold (``envs/*.toml``)."""


def self_contacts(sim: Any, legs: np.ndarray) -> list[tuple[float, str, str, bool]]:
    """(depth m, body, body, legs pair) of every interpenetrating robot geom pair, deepest first.
    ``legs`` (2, nbody) bool: the bodies of the left and right leg."""
    m, d = sim.scene.model, sim.data
    robot = sim.scene.robot_geom
    out = []
    for c in d.contact[: d.ncon]:
        g1, g2 = int(c.geom1), int(c.geom2)
        if not (robot[g1] and robot[g2]) or c.dist >= 0:
            continue
        b1, b2 = int(m.geom_bodyid[g1]), int(m.geom_bodyid[g2])
        pair = bool((legs[0, b1] and legs[1, b2]) or (legs[1, b1] and legs[0, b2]))
        out.append((-float(c.dist), mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b1) or str(b1),
                    mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b2) or str(b2), pair))
    return sorted(out, reverse=True)


def episode(env: SocialAffordanceEnv, instance: str, seed: int, replay: bool) -> dict[str, Any]:
    """One episode's row (see the module docstring)."""
    env.reset(seed=seed, options={"instance": instance})
    sim = env.simulator
    m = sim.scene.model
    legs = np.stack([subtree_mask(m, int(b)) for b in sim.scene.limb_body_ids[2:4]])
    at_reset = self_contacts(sim, legs)
    keys = sim.robot_key_frames()
    zero = np.zeros(env.action_space.shape, env.action_space.dtype)
    _, _, term, trunc, info = env.step(zero)
    at_step1 = self_contacts(sim, legs)
    row: dict[str, Any] = {
        "instance": instance, "seed": seed,
        "reset_depth": at_reset[0][0] if at_reset else 0.0,
        "reset_legs_depth": max((c[0] for c in at_reset if c[3]), default=0.0),
        "reset_pairs": [list(c) for c in at_reset[:4]],
        "step1_depth": at_step1[0][0] if at_step1 else 0.0,
        "step1_legs_depth": max((c[0] for c in at_step1 if c[3]), default=0.0),
        "step1_reason": info["termination_reason"],
        "ankle_gap_xy": float(np.linalg.norm(keys[3, :2] - keys[4, :2])),
    }
    if replay:
        steps = 1
        while not (term or trunc):
            _, _, term, trunc, info = env.step(zero)
            steps += 1
        worst = [f.worst for f in sim.scorer.failures if f.kind == "self_collision"]
        row.update(success=bool(info["success"]), reason=info["termination_reason"], steps=steps,
                   self_collision_worst=max(worst, default=0.0))
    return row


def summarize(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Counts of one (data set, label, robot) group."""
    out: dict[str, Any] = {
        "episodes": len(rows),
        "reset_any": sum(r["reset_depth"] > 0 for r in rows),
        "reset_legs": sum(r["reset_legs_depth"] > 0 for r in rows),
        "reset_over_threshold": sum(r["reset_depth"] > THRESHOLD for r in rows),
        "step1_any": sum(r["step1_depth"] > 0 for r in rows),
        "step1_legs": sum(r["step1_legs_depth"] > 0 for r in rows),
        "step1_self_collision": sum(r["step1_reason"] == "self_collision" for r in rows),
        "max_reset_depth_cm": 100 * max((r["reset_depth"] for r in rows), default=0.0),
    }
    if rows and "success" in rows[0]:
        out["success"] = sum(r["success"] for r in rows)
        out["reasons"] = dict(Counter(r["reason"] or "instance_end" for r in rows))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", nargs="+", default=list(DATA), metavar="SPEC", help="recorded data sets (kind:PATH)")
    ap.add_argument("--labels", nargs="+", default=None, help="only these labels (default: every label with a task)")
    ap.add_argument("--robots", nargs="+", default=["ours"])
    ap.add_argument("--mjcf", nargs="+", default=[], metavar="ROBOT=PATH", help="the MJCF of a robot not shipped")
    ap.add_argument("--models", type=Path, default=None,
                    help="affordance models DIR/<label>.npz (default: the recording)")
    ap.add_argument("--physics", default="fast")
    ap.add_argument("--seed", type=int, default=0, help="reset seed of every episode")
    ap.add_argument("--limit", type=int, default=None, help="at most this many instances per label")
    ap.add_argument("--replay", action="store_true", help="play every episode to its end")
    ap.add_argument("--json", type=Path, default=None)
    a = ap.parse_args()
    mjcf = dict(item.split("=", 1) for item in a.mjcf)
    results: dict[str, Any] = {"settings": {k: str(v) if isinstance(v, Path) else v for k, v in vars(a).items()},
                               "groups": []}
    t0, c0 = time.perf_counter(), time.process_time()
    for spec in a.data:
        dataset = list(load_dataset(spec))
        labels = sorted({i.label for i in dataset})
        for label in labels:
            if a.labels is not None and label not in a.labels:
                continue
            try:
                task_for_label(label)
            except ConfigError:
                continue
            inters = [i for i in dataset if i.label == label][: a.limit]
            model = None if a.models is None else {label: SocialAffordanceModel.load(a.models / f"{label}.npz")}
            for robot_name in a.robots:
                robot = load_robot(robot_name, mjcf=mjcf.get(robot_name))
                env = SocialAffordanceEnv(interactions=label, data=inters, robot=robot, action_mode="residual",
                                          model=model, physics=a.physics)
                rows = [episode(env, i.instance_id, a.seed, a.replay) for i in inters]
                env.close()
                group = {"data": spec.split(":", 1)[0], "label": label, "robot": robot_name, **summarize(rows),
                         "rows": rows}
                results["groups"].append(group)
                s = {k: v for k, v in group.items() if k != "rows"}
                print(json.dumps(s), flush=True)
    results["wall_s"], results["cpu_s"] = time.perf_counter() - t0, time.process_time() - c0
    print("| data | label | robot | episodes | self-contact at reset (legs pair) | > 2 cm at reset | "
          "self_collision on step 1 | deepest at reset (cm) |" + (" success | reasons |" if a.replay else ""))
    print("|---|---|---|---:|---:|---:|---:|---:|" + ("---:|---|" if a.replay else ""))
    for g in results["groups"]:
        line = (f"| {g['data']} | {g['label']} | {g['robot']} | {g['episodes']} | "
                f"{g['reset_any']} ({g['reset_legs']}) | {g['reset_over_threshold']} | {g['step1_self_collision']} | "
                f"{g['max_reset_depth_cm']:.1f} |")
        if a.replay:
            line += f" {g['success']} | " + ", ".join(f"{k} {v}" for k, v in sorted(g["reasons"].items())) + " |"
        print(line)
    print(f"wall {results['wall_s']:.0f} s, CPU {results['cpu_s']:.0f} s")
    if a.json is not None:
        atomic_write_text(a.json, json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
