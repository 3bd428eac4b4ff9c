"""Contact in physics under causal synthesis: sub-goal success and the geometry of each contact, per robot.

For each synthetic interaction the instances are split as the demo splits them (the last actor pairs
held out, ``socialaff_sim.demo.pipeline.held_out``); an affordance model is fitted on the rest with the
demo's settings (30 MCMC iterations, seed 0; cached in ``--models``) and drives the robot through
``socialaff_sim.retarget.model_source.ModelSource`` with causal synthesis (``SynthesisConfig.reactive()``,
what the demo, ``simulate`` and the environment run). Each held-out instance is simulated once per robot
and per contact-completion setting (``--completion on`` / ``off`` / ``both``;
``socialaff_sim.sim.contact_completion``).

Per episode it records what a person watching the video would check:

* every sub-goal's success (latched) and the failure conditions triggered;
* the *held phase*: the frames whose recorded sub-event is the interaction's contact phase (``shake``,
  ``strike``, ``pull``, ``catch``/``hold``, ``transfer``), from the recording, not from the robot;
  over it, the sub-goal's gap between the robot's and the person's (or the object's) geoms
  (``SubgoalScorer.measure_gaps``, ``mj_geomDistance``): median and max, and the fraction of its frames in
  contact now;
* the robot's own *contact span*, from its first to its last frame in contact: the gap's median and max over
  it (a gap above zero inside it is a contact lost and found again);
* for the high five, at the frame of the held phase where the hands come closest: the height of the
  robot's nearer hand (the mean of its collidable geoms' centres) and of the person's hand sphere, against
  the robot's and the person's shoulder heights.

Run with OMP_NUM_THREADS=1 (set here unless given). Example::

    OMP_NUM_THREADS=1 nice -n 10 python scripts/bench_contact.py --robots ours unitree_h1 \\
        --mjcf-h1 ../shared/robots/unitree_h1/h1.xml --instances 4 --completion both --json contact.json
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time
from pathlib import Path
from typing import Any

os.environ.setdefault("OMP_NUM_THREADS", "1")
if not os.environ.get("DISPLAY"):
    os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

from socialaff_sim._atomic import atomic_write_text  # noqa: E402
from socialaff_sim.data.interaction import Interaction  # noqa: E402
from socialaff_sim.data.synthetic import INTERACTIONS, generate_dataset  # noqa: E402
from socialaff_sim.demo.pipeline import held_out  # noqa: E402
from socialaff_sim.inference import SynthesisConfig  # noqa: E402
from socialaff_sim.learning import SocialAffordanceModel  # noqa: E402
from socialaff_sim.learning.config import LearningConfig  # noqa: E402
from socialaff_sim.retarget.model_source import ModelSource  # noqa: E402
from socialaff_sim.retarget.robot import load_robot  # noqa: E402
from socialaff_sim.sim.episode import run_episode  # noqa: E402
from socialaff_sim.sim.simulator import SimConfig, Simulator  # noqa: E402
from socialaff_sim.sim.tasks import task_for_label  # noqa: E402

HELD = {"shake_hands": ("shake",), "high_five": ("strike",), "pull_up": ("pull",),
        "throw_catch": ("catch", "hold"), "hand_over": ("transfer",)}
"""The recorded sub-events during which the interaction's contact holds."""


def fit_model(data: Any, label: str, n_test: int, iterations: int, seed: int, models: Path | None
              ) -> tuple[SocialAffordanceModel, list[Interaction]]:
    """The demo's model of ``label`` (fitted, or read from ``models``) and the held-out instances."""
    train, test = held_out(list(data.of_label(label)), n_test)
    path = None if models is None else models / f"{label}_it{iterations}_s{seed}.npz"
    if path is not None and path.exists():
        return SocialAffordanceModel.load(path), test
    model = SocialAffordanceModel(learning=LearningConfig(iterations=iterations)).fit(
        train, rng=np.random.default_rng(seed))
    if path is not None:
        model.save(path)
    return model, test


class Recorder:
    """Per frame: the robot's hand centres, the person's hand spheres and both agents' shoulder heights."""

    def __init__(self) -> None:
        self.robot_hands: list[np.ndarray] = []
        self.human_hands: list[np.ndarray] = []
        self.robot_shoulder: list[float] = []

    def __call__(self, sim: Simulator, result: Any, subevent: str | None) -> None:
        sc, d = sim.scene, sim.data
        self.robot_hands.append(np.stack([d.geom_xpos[sc.hand_geom[s]].mean(axis=0) for s in (0, 1)]))
        self.human_hands.append(d.geom_xpos[sc.human_geom_ids[-2:]].copy())
        self.robot_shoulder.append(float(np.mean(d.xpos[sc.limb_body_ids[:2], 2])))


def _shoulder_z(inter: Interaction, sim: Simulator) -> np.ndarray:
    """(T,) the person's (agent 0) shoulder height per frame, world frame (NaN without shoulder joints)."""
    names = inter.joint_names
    cols = [names.index(n) for n in ("left_shoulder", "right_shoulder") if n in names]
    if not cols:
        return np.full(inter.n_frames, np.nan)
    return np.nanmean(sim.pose.joints[:, cols, 2], axis=1)


def episode(sim: Simulator, model: SocialAffordanceModel, inter: Interaction, seed: int) -> dict[str, Any]:
    """Run one causal episode; returns its record."""
    rec = Recorder()
    source = ModelSource(model, seed=seed, config=SynthesisConfig.reactive())
    tic = time.perf_counter()
    metrics = run_episode(sim, source, inter, on_frame=rec)
    wall = time.perf_counter() - tic
    names = inter.subevent_names
    sub = inter.subevents
    held = np.zeros(inter.n_frames, dtype=bool)
    if sub is not None:
        held = np.isin(np.array([names[i] if i >= 0 else "" for i in sub]), HELD.get(inter.label, ()))
    row: dict[str, Any] = {
        "instance": inter.instance_id, "success": bool(metrics["success"]),
        "subgoals": {s["name"]: bool(s["success"]) for s in metrics["subgoals"]},
        "failures": [f["kind"] for f in metrics["failures"] if f["triggered"]],
        "held_frames": int(held.sum()), "wall_seconds": wall,
        "contact_phase_support": metrics["support"]["contact_phase"],
    }
    for s in metrics["subgoals"]:
        # Per-frame lists start at frame 1 (the first step); frame 0 is the reset.
        gaps = np.array([np.nan if g is None else g for g in s["gap_m_per_frame"]], dtype=np.float64)
        now = np.array(s["in_contact_per_frame"], dtype=bool)
        h = held[1:]
        g = gaps[h]
        # The robot's own contact span: its first to its last touching frame (a gap inside it is a contact
        # lost and found again, visible in the video).
        touch = np.flatnonzero(now)
        span = gaps[touch[0]:touch[-1] + 1] if len(touch) else np.zeros(0)
        row[s["name"]] = {
            "gap_per_frame_m": [None if not np.isfinite(v) else round(float(v), 4) for v in gaps],
            "span_frames": int(len(span)),
            "gap_span_median_m": float(np.nanmedian(span)) if np.isfinite(span).any() else None,
            "gap_span_max_m": float(np.nanmax(span)) if np.isfinite(span).any() else None,
            "gap_held_median_m": float(np.nanmedian(g)) if np.isfinite(g).any() else None,
            "gap_held_max_m": float(np.nanmax(g)) if np.isfinite(g).any() else None,
            "gap_held_min_m": float(np.nanmin(g)) if np.isfinite(g).any() else None,
            "touching_held_fraction": float(now[h].mean()) if h.any() else None,
            "contact_seconds": float(s["contact_seconds"]),
        }
    if inter.label == "high_five" and held.any():
        rh, hh = np.array(rec.robot_hands), np.array(rec.human_hands)  # (T, 2, 3) each
        d = np.linalg.norm(rh[:, :, None] - hh[:, None, :], axis=-1).min(axis=(1, 2))
        t = int(np.flatnonzero(held)[np.argmin(d[held])])
        pair = np.unravel_index(np.argmin(np.linalg.norm(rh[t][:, None] - hh[t][None], axis=-1)), (2, 2))
        row["strike"] = {
            "frame": t, "centre_distance_m": float(d[t]),
            "robot_hand_z": float(rh[t, pair[0], 2]), "robot_shoulder_z": rec.robot_shoulder[t],
            "person_hand_z": float(hh[t, pair[1], 2]), "person_shoulder_z": float(_shoulder_z(inter, sim)[t]),
        }
        # Where the hands touched (any frame the sub-goal's contact held): the touching pair above both
        # agents' shoulders, or not (a brush of hanging hands also meets the sub-goal).
        sub = metrics["subgoals"][0]
        touch = np.flatnonzero(np.array(sub["in_contact_per_frame"], dtype=bool)) + 1  # per-frame lists start at 1
        above = []
        person_sh = _shoulder_z(inter, sim)
        for f in touch:
            p = np.unravel_index(np.argmin(np.linalg.norm(rh[f][:, None] - hh[f][None], axis=-1)), (2, 2))
            above.append(bool(rh[f, p[0], 2] > rec.robot_shoulder[f] and hh[f, p[1], 2] > person_sh[f]))
        row["strike"]["touch_frames"] = [int(f) for f in touch]
        row["strike"]["touch_frames_above_shoulders"] = int(sum(above))
    return row


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--interactions", nargs="+", default=list(INTERACTIONS))
    ap.add_argument("--robots", nargs="+", default=["ours"], help="ours, cmu, unitree_h1, unitree_g1")
    ap.add_argument("--mjcf-h1", default=None, help="path of the Unitree H1's h1.xml (for --robots unitree_h1)")
    ap.add_argument("--mjcf-g1", default=None, help="path of the Unitree G1's g1_29dof.xml")
    ap.add_argument("--instances", type=int, default=4, help="held-out instances per interaction (default 4)")
    ap.add_argument("--iterations", type=int, default=30, help="MCMC iterations of the fit (the demo's 30)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--completion", choices=("on", "off", "both", "default"), default="both",
                    help="contact completion on, off, both, or the simulator's default (default both)")
    ap.add_argument("--set", nargs="*", default=[], metavar="FIELD=VALUE",
                    help="with completion on: change ContactCompletionConfig fields (floats), e.g. --set capture=0.25")
    ap.add_argument("--models", default=None, help="cache the fitted models in this folder")
    ap.add_argument("--json", default=None, help="write the records here")
    args = ap.parse_args(argv)
    models = None if args.models is None else Path(args.models)
    if models is not None:
        models.mkdir(parents=True, exist_ok=True)
    data = generate_dataset(args.seed)
    settings = {"on": ["on"], "off": ["off"], "both": ["off", "on"], "default": ["default"]}[args.completion]
    mjcf = {"unitree_h1": args.mjcf_h1, "unitree_g1": args.mjcf_g1}
    rows: list[dict[str, Any]] = []
    start = time.perf_counter()
    for label in args.interactions:
        model, test = fit_model(data, label, args.instances, args.iterations, args.seed, models)
        for robot_name in args.robots:
            robot = load_robot(robot_name, mjcf=mjcf.get(robot_name))
            for setting in settings:
                config = SimConfig()
                if setting != "default":
                    base = dataclasses.replace(SimConfig().contact_completion,  # type: ignore[arg-type]
                                               **{k: float(v) for k, v in (kv.split("=", 1) for kv in args.set)})
                    config = dataclasses.replace(config, contact_completion=None if setting == "off" else base)
                sim = Simulator(robot, task_for_label(label), config)
                for inter in test:
                    row = episode(sim, model, inter, args.seed)
                    row.update(interaction=label, robot=robot_name, completion=setting)
                    rows.append(row)
                    goals = " ".join(f"{k}={'yes' if v else 'no'}" for k, v in row["subgoals"].items())
                    extra = ""
                    for name in row["subgoals"]:
                        g = row[name]
                        if g["gap_held_median_m"] is not None:
                            extra += (f" gap held p50 {100 * g['gap_held_median_m']:.1f} cm max "
                                      f"{100 * g['gap_held_max_m']:.1f} cm touching {100 * g['touching_held_fraction']:.0f}%")
                        if g["span_frames"]:
                            extra += (f"; contact span {g['span_frames']} frames, gap p50 "
                                      f"{100 * g['gap_span_median_m']:.1f} max {100 * g['gap_span_max_m']:.1f} cm")
                    if "strike" in row:
                        s = row["strike"]
                        extra += (f" strike: robot hand z {s['robot_hand_z']:.2f} (its shoulder {s['robot_shoulder_z']:.2f}),"
                                  f" person hand z {s['person_hand_z']:.2f} (shoulder {s['person_shoulder_z']:.2f}),"
                                  f" centres {100 * s['centre_distance_m']:.0f} cm; touching above both shoulders in"
                                  f" {s['touch_frames_above_shoulders']} of {len(s['touch_frames'])} contact frames")
                    print(f"{robot_name:10s} {setting:7s} {row['instance']}: {goals} fail={row['failures']}{extra}",
                          flush=True)
    summary: dict[str, Any] = {}
    for r in rows:
        key = f"{r['robot']}/{r['interaction']}/{r['completion']}"
        s = summary.setdefault(key, {"n": 0, "success": 0, "subgoals": {}})
        s["n"] += 1
        s["success"] += int(r["success"])
        for k, v in r["subgoals"].items():
            s["subgoals"][k] = s["subgoals"].get(k, 0) + int(v)
    print()
    for k, s in summary.items():
        print(f"{k}: success {s['success']}/{s['n']}; " + ", ".join(f"{n} {v}/{s['n']}" for n, v in s["subgoals"].items()))
    result = {"settings": vars(args), "rows": rows, "summary": summary, "wall_seconds": time.perf_counter() - start}
    if args.json:
        atomic_write_text(args.json, json.dumps(result, indent=2) + "\n")
    return result


if __name__ == "__main__":
    main()
