"""``socialaff-sim synthesize``: agent 1's reaction to one recorded instance, from a fitted model."""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from .._atomic import output_folder
from .validate import add_data_options, declare_outputs, int_range, non_negative_int
from .help_format import HelpFormatter

__all__ = ["register"]


def _run(args: argparse.Namespace) -> int:
    from ..data import load_dataset, save_interaction
    from ..errors import ModelError
    from ..evaluation.metrics import joint_error, key_joint_error
    from ..inference.protocol import Prediction, observed_part
    from ..inference import BodyFitter, SynthesisConfig, synthesize
    from ..errors import ConfigError
    from ..inference.plot import plot_key_joint_tracks
    from ..inference.presets import preset
    from ..learning.estimator import SocialAffordanceModel
    from ..model.joints import instance_frame

    model = SocialAffordanceModel.load(args.model)
    everything = load_dataset(args.data, policy=args.policy, units=args.units)
    inter = everything.by_id(args.instance)
    if inter.label != model.label_:
        raise ModelError(
            f"--instance {inter.instance_id!r} is a {inter.label!r} interaction but {args.model} models "
            f"{model.label_!r}: choose a {model.label_!r} instance, or fit a {inter.label!r} model first "
            f"(socialaff-sim fit --data {args.data} --interaction {inter.label} --out {inter.label}.npz)"
        )
    dataset = everything.of_label(model.label_)
    others = [i for i in dataset if i.instance_id != inter.instance_id]
    if not others:
        raise ModelError(f"{args.data}: the full-body fit needs other {model.label_!r} instances besides {inter.instance_id!r}")
    body = BodyFitter().fit_interactions(others, agent=1, rng=np.random.default_rng(args.seed))
    mode = args.mode or ("online" if args.preset == "paper" else "offline")
    if args.preset == "paper":
        if mode == "offline" or args.lookahead:
            raise ConfigError("--preset paper is the paper's causal Algorithm 2: it takes neither --mode offline nor --lookahead")
        config = dataclasses.replace(preset("paper").synthesis, n_observed=args.observed)
    elif mode == "offline":
        config = SynthesisConfig.offline(n_observed=args.observed)
    else:
        config = dataclasses.replace(preset("default").synthesis, n_observed=args.observed, lookahead=args.lookahead)
    start = time.perf_counter()
    keys, skel, subs, _ = synthesize(
        model, observed_part(inter, args.observed), rng=np.random.default_rng(args.seed), body=body, config=config
    )
    seconds = time.perf_counter() - start
    assert skel is not None  # a body fitter was given
    out = Path(args.out)
    with output_folder(out) as staging:  # both files or neither; a second writer is refused
        joints = inter.joints.copy()
        joints[:, 1] = skel
        valid = np.array(inter.valid, copy=True)
        valid[:, 1] = np.isfinite(skel).all(axis=-1)
        synthesized = inter.replace(
            joints=np.where(valid[..., None], joints, np.nan),
            valid=valid,
            subevents=subs,
            subevent_names=model.subevent_names_,
            source=f"synthesized by socialaff-sim from {args.model} (seed {args.seed}) for {inter.source or inter.instance_id}",
            instance_id=f"{inter.instance_id}_synth",
        )
        track_path = save_interaction(synthesized, staging / f"{inter.instance_id}_synth.npz")
        frame = instance_frame(inter)
        plot_path = plot_key_joint_tracks(
            staging / f"{inter.instance_id}_synthesis.png",
            inter.fps,
            frame.to_canonical(inter.key_joints()[:, 1]),
            frame.to_canonical(keys),
            subs,
            model.subevent_names_,
            human=frame.to_canonical(inter.key_joints()[:, 0]),
            n_observed=args.observed,
            title=f"{inter.instance_id}: agent 1 synthesized by the affordance model ({model.label_})",
        )
    track_path, plot_path = out / track_path.name, out / plot_path.name
    n = inter.n_frames - args.observed
    pred = Prediction(joints=skel, key_joints=keys, subevents=subs, n_observed=args.observed)
    print(f"{inter.instance_id}: {inter.n_frames} frames, {args.observed} observed, {n} synthesized in {seconds:.2f} s ({n / seconds:.0f} frames/s)")
    print(
        f"average distance to the recording: key joints {key_joint_error(pred, inter):.3f} m, "
        f"full skeleton {joint_error(pred, inter):.3f} m"
    )
    print("inferred sub-events:", " -> ".join(dict.fromkeys(model.subevent_names_[s] for s in subs if s >= 0)))
    print(f"wrote {track_path} (read with: socialaff-sim data inspect npz:{out}) and {plot_path}")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add ``synthesize``."""
    p = subparsers.add_parser(
        "synthesize",
        help="synthesize agent 1's reaction to a recorded instance",
        description="Synthesize the second person's (agent 1's) motion in reaction to the first person of one "
        "recorded instance with a fitted model (Algorithm 2), full body; writes the synthesized track (.npz), a "
        "plot against the recording and prints the error.",
        epilog="example (a model fitted on synthetic:0, a recording from synthetic:1 it never saw):\n"
        "  socialaff-sim synthesize --model model.npz --data synthetic:1 --instance shake_hands_020 --out syn/",
        formatter_class=HelpFormatter,
    )
    p.add_argument("--model", required=True, help="fitted model file (socialaff-sim fit)")
    p.add_argument("--data", required=True, help="dataset spec, e.g. synthetic or sbu:PATH")
    p.add_argument("--instance", required=True, help="instance id (or a unique prefix, or a position)")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--observed", type=int_range(1), default=10, help="T0: observed frames of agent 1 (default 10)")
    p.add_argument("--seed", type=non_negative_int, default=0, help="seed of the synthesis (default 0)")
    p.add_argument(
        "--mode", choices=("offline", "online"), default=None,
        help="offline (the default with --preset default): agent 0's whole track is read, its parse fixes the "
        "sub-events (an upper bound, not a reaction); online: causal Algorithm 2, as the simulator runs it "
        "(the only mode of --preset paper)",
    )
    p.add_argument(
        "--preset", choices=("default", "paper"), default="default",
        help="synthesis settings: this project's (default) or Algorithm 2 exactly as the paper states it (paper); "
        "the model's own settings were fixed when it was fitted (fit --preset)",
    )
    p.add_argument("--lookahead", action="store_true", help="online mode: use agent 0's recorded position at the predicted end")
    add_data_options(p)
    declare_outputs(p, out="folder")
    p.set_defaults(func=_run)
