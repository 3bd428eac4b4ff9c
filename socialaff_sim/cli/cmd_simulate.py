"""``socialaff-sim simulate``: one instance through the whole loop, scored in physics, with a video.

Observed human (agent 0) → key-joint source (the synthesizer, or the recorded
agent 1 with ``--source gt``) → human-to-robot scaling → mink IK → MuJoCo physics
→ sub-goal scoring. Writes DIR/metrics.json and, unless ``--no-video``,
DIR/video.mp4 and DIR/contact_sheet.png.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

from .._atomic import output_folder
from .validate import add_data_options, add_physics_option, declare_outputs, int_range
from .progress import FrameProgress, Reporter

from .help_format import HelpFormatter

__all__ = ["register", "run"]


def _source(args: argparse.Namespace) -> object:
    from ..retarget.model_source import model_source
    from ..retarget.sources import GroundTruthSource

    if args.source == "gt":
        return GroundTruthSource()
    return model_source(args.model, offline=args.synthesis == "offline")


def run(args: argparse.Namespace) -> int:
    """Simulate one instance; returns 0 on completion (whatever the sub-goals' outcome)."""
    from .._atomic import atomic_write_text
    from ..data import load_dataset
    from ..errors import RenderingUnavailableError
    from ..retarget.robot import load_robot
    from ..sim.episode import run_episode
    from ..sim.simulator import SimConfig, Simulator
    from ..sim.tasks import load_task, task_for_label

    say = Reporter(args.quiet)
    robot = load_robot(args.robot, mjcf=args.mjcf)  # a wrong robot or --mjcf fails before any data is read
    source = _source(args)
    dataset = load_dataset(args.data, policy=args.policy, units=args.units)
    inter = dataset.by_id(args.instance)
    task = load_task(args.task) if args.task else task_for_label(inter.label)
    physics = SimConfig.mode(args.physics or robot.physics)
    if args.no_contact_completion:
        physics = dataclasses.replace(physics, contact_completion=None)
    sim = Simulator(robot, task, physics)
    out = Path(args.out)
    with output_folder(out) as staging:  # metrics, video and sheet together or not at all

        recorder = None
        video_note = "disabled (--no-video)"
        if not args.no_video:
            from ..sim.video import EpisodeRecorder

            try:
                recorder = EpisodeRecorder(sim, staging / "video.mp4", staging / "contact_sheet.png",
                                           width=args.width, height=args.height)
            except RenderingUnavailableError as exc:
                video_note = f"not written: {exc}"
                print(f"socialaff-sim simulate: warning: no video: {exc}", file=sys.stderr)
        label = f"{inter.instance_id} on {sim.robot.name}"
        if recorder is not None:
            with recorder:
                metrics = run_episode(sim, source, inter, on_frame=FrameProgress(say, label, recorder))  # type: ignore[arg-type]
            video_note = str(out / "video.mp4")
        else:
            metrics = run_episode(sim, source, inter, on_frame=FrameProgress(say, label))  # type: ignore[arg-type]

        metrics["source"] = args.source
        metrics["data"] = args.data
        metrics["model"] = args.model
        metrics["video"] = video_note
        atomic_write_text(staging / "metrics.json", json.dumps(metrics, indent=2) + "\n")

    print(f"{inter.instance_id} ({inter.label}, {inter.n_frames} frames at {inter.fps:g} fps) "
          f"robot {sim.robot.name}, source {args.source}, task {task.interaction}")
    for s in metrics["subgoals"]:
        when = f" at {s['time']:.2f} s" if s["time"] is not None else ""
        print(f"  sub-goal {s['name']:<16s} {'met' if s['success'] else 'missed'}{when}  (contact {s['contact_seconds']:.2f} s)")
    for f in metrics["failures"]:
        if f["triggered"]:
            print(f"  failure  {f['kind']:<16s} at {f['time']:.2f} s (worst {f['worst']:.3g}, threshold {f['threshold']:g})")
    when = "" if metrics["outcome_time"] is None else f" at {metrics['outcome_time']:.2f} s"
    print(f"  outcome  {metrics['outcome']}{when}")
    within = metrics["ik_error_reachable_within_2cm"]
    ik = metrics["ik_ms_per_frame"]
    print(f"  IK: {ik['mean']:.2f} ms/frame; reachable key-frame targets within 2 cm: "
          f"{'n/a' if within is None else f'{100 * within:.1f} %'}")
    print(f"  loop: {metrics['wall_seconds']:.2f} s wall for {metrics['simulated_seconds']:.2f} s simulated "
          f"(real-time factor {metrics['real_time_factor']:.1f})")
    print(f"wrote {out / 'metrics.json'}; video: {video_note}")
    if args.source == "model":
        print("next: compare with the recorded reaction: the same command with --source gt")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``simulate``."""
    p = subparsers.add_parser(
        "simulate",
        help="make a MuJoCo humanoid react to one recorded person; score it in physics",
        description="Replay one recorded person (agent 0) in MuJoCo while a humanoid robot reacts as the model "
        "synthesizes (or as the recorded agent 1 did, --source gt), retargeted with mink; score the task's "
        "sub-goals and write OUT/metrics.json, OUT/video.mp4 and OUT/contact_sheet.png.",
        epilog="example (a model fitted on synthetic:0, a recording from synthetic:1 it never saw):\n"
        "  socialaff-sim simulate --model model.npz --data synthetic:1 --instance shake_hands_020 --out sim/",
        formatter_class=HelpFormatter,
    )
    p.add_argument("--model", help="affordance model file (model.npz); needed with --source model")
    p.add_argument("--data", default="synthetic",
                   help="dataset spec: sbu:PATH, handover:PATH, nuisi:PATH, hhoi:PATH, npz:DIR or synthetic[:SEED] "
                        "(default synthetic)")
    p.add_argument("--instance", required=True, help="instance id (or a unique prefix, or a position index)")
    p.add_argument("--robot", default="ours",
                   help="robot: 'cmu' (dm_control CMU humanoid), 'ours' (the project's 1.3 m robot) "
                        "'unitree_h1', 'unitree_g1' (need --mjcf) or the path of a mapping .toml (docs/robots.md); "
                        "default ours")
    p.add_argument("--mjcf", help="the robot's MJCF file, for robots whose model the project does not ship "
                                  "(unitree_h1: your h1.xml; unitree_g1: your g1_29dof.xml)")
    p.add_argument("--source", choices=("model", "gt"), default="model",
                   help="key joints from the affordance model's synthesis, or the recorded agent 1 (gt)")
    p.add_argument("--synthesis", choices=("online", "offline"), default="online",
                   help="with --source model: online (default) reacts causally to the human (SynthesisConfig.reactive()); offline reads the "
                   "replayed human's whole recording first, as 'evaluate' does")
    p.add_argument("--task", help="task file name or path (default: the one whose interaction matches the instance)")
    p.add_argument("--out", required=True, help="output folder for metrics.json, video.mp4, contact_sheet.png")
    p.add_argument("--no-video", action="store_true", help="skip rendering")
    p.add_argument("--no-contact-completion", action="store_true",
                   help="send the scaled targets to the IK as they are (no blending of a wrist onto the contact "
                        "the reaction is making; docs/design.md)")
    add_physics_option(p)
    p.add_argument("--width", type=int_range(16, 4096), default=640, help="video width in pixels, 16-4096 (default 640)")
    p.add_argument("--height", type=int_range(16, 4096), default=480, help="video height in pixels, 16-4096 (default 480)")
    add_data_options(p)
    declare_outputs(p, out="folder")
    p.set_defaults(func=run)
