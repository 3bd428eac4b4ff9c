"""One catch simulated and looked at: the video and a sheet of the frames around the catch (issue 25).

Simulates one instance as ``socialaff-sim simulate`` does (the recorded agent 1 with ``--source gt``, else the model's
causal synthesis, ``ModelSource(model, seed, SynthesisConfig.reactive())`` as the demo runs it), in a physics mode,
with the contact completion's settings changed (``--completion FIELD=VALUE ...``, e.g. ``catch_flight=True``), and
writes OUT/video.mp4, OUT/catch_sheet.png (the frames of the sub-events ``--subevents``, default the flight and the
catch, and two after, at most 12) and OUT/metrics.json; prints whether the ball was caught and each sheet frame's
ball height and distance to the nearer hand::

    MUJOCO_GL=egl PYTHONPATH=$PWD python scripts/catch_frames.py --instance throw_catch_000 --source gt \\
        --robot unitree_h1 --mjcf ../shared/robots/unitree_h1/h1.xml --completion catch_flight=True --out OUT
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import json
from pathlib import Path

import numpy as np

from socialaff_sim._atomic import atomic_write_text
from socialaff_sim.data import load_dataset
from socialaff_sim.inference import SynthesisConfig
from socialaff_sim.learning.estimator import SocialAffordanceModel
from socialaff_sim.retarget.model_source import ModelSource
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.render import pillow
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.stage import key_frames
from socialaff_sim.sim.tasks import task_for_label
from socialaff_sim.sim.video import EpisodeRecorder, caption_lines, contact_sheet


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--instance", required=True)
    p.add_argument("--data", default="synthetic", help="dataset spec (default synthetic)")
    p.add_argument("--source", choices=("model", "gt"), default="model")
    p.add_argument("--model", help="model.npz (with --source model)")
    p.add_argument("--seed", type=int, default=0, help="the synthesis's seed (the demo's: 0)")
    p.add_argument("--robot", default="ours")
    p.add_argument("--mjcf")
    p.add_argument("--physics", choices=("harness", "standing"), default="harness")
    p.add_argument("--completion", nargs="*", default=[], metavar="FIELD=VALUE")
    p.add_argument("--subevents", nargs="*", default=["flight", "catch"])
    p.add_argument("--out", required=True)
    args = p.parse_args()
    if args.source == "model" and not args.model:
        p.error("--source model needs --model")
    robot = load_robot(args.robot, mjcf=args.mjcf)
    inter = load_dataset(args.data).by_id(args.instance)
    physics = SimConfig.mode(args.physics)
    over = {k: ast.literal_eval(v) for k, v in (item.split("=", 1) for item in args.completion)}
    if over:
        physics = dataclasses.replace(physics, contact_completion=dataclasses.replace(physics.contact_completion, **over))
    sim = Simulator(robot, task_for_label(inter.label), physics)
    source = (GroundTruthSource() if args.source == "gt"
              else ModelSource(SocialAffordanceModel.load(args.model), seed=args.seed, config=SynthesisConfig.reactive()))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    frames: dict[int, np.ndarray] = {}
    info: dict[int, tuple[str | None, float, float]] = {}
    with EpisodeRecorder(sim, out / "video.mp4", None) as rec:
        def on_frame(s: Simulator, result: object, subevent: str | None) -> None:
            rec(s, result, subevent)  # type: ignore[arg-type]
            sc, d = s.scene, s.data
            ball = np.array(d.qpos[sc.object_qadr:sc.object_qadr + 3])
            hands = key_frames(sc, d)[1:3]
            info[s.frame] = (subevent, float(ball[2]), float(np.linalg.norm(hands - ball, axis=1).min()))
            frames[s.frame] = rec.renderer.render(caption_lines(s, subevent))  # again, kept for the sheet

        metrics = run_episode(sim, source, inter, on_frame=on_frame)
    chosen = [f for f in sorted(info) if info[f][0] in args.subevents]
    if chosen:
        chosen = list(range(chosen[0], min(max(chosen) + 3, max(info) + 1)))[:12]
    if chosen:
        pillow().Image.fromarray(contact_sheet([frames[f] for f in chosen], cols=4)).save(out / "catch_sheet.png")
    atomic_write_text(out / "metrics.json", json.dumps(metrics, indent=1) + "\n")
    print(f"{inter.instance_id} {robot.name} {args.physics} source {args.source} completion {over or 'default'}: "
          + ", ".join(f"{g['name']} {'met at %.2f s' % g['time'] if g['success'] else 'missed'}"
                      for g in metrics["subgoals"])
          + "; failures: " + (", ".join(f["kind"] for f in metrics["failures"] if f["triggered"]) or "none"))
    for f in chosen:
        sub, z, gap = info[f]
        print(f"  frame {f:3d} {sub or '-':<8} ball {z:5.2f} m up, nearest wrist frame {gap:5.2f} m")


if __name__ == "__main__":
    main()
