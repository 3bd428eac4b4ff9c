"""Synthesis speed (Algorithm 2): synthesized frames per second on one core, per interaction.

Fits one model per synthetic interaction on 18 instances (the learning settings are a
flag; synthesis speed does not depend on them), then synthesizes agent 1 for the 6
held-out instances and reports frames per second and the key-joint error.

    OMP_NUM_THREADS=1 python scripts/bench_synthesis.py [--synthesis offline,reactive,paper] [--iterations 100] [--seed 0] [--json PATH]

Modes: ``offline`` is ``SynthesisConfig.offline()``, as ``socialaff-sim evaluate`` runs the model;
``reactive`` is ``SynthesisConfig.reactive()``, causal, as the simulator and the environment run it;
``paper`` is ``SynthesisConfig()``, the paper's Algorithm 2 exactly. The models are fitted once.

``--json PATH`` also writes the table to PATH (atomically).
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from socialaff_sim._atomic import atomic_write_text  # noqa: E402
from socialaff_sim.data.synthetic import INTERACTIONS, generate_dataset  # noqa: E402
from socialaff_sim.evaluation.metrics import key_joint_error  # noqa: E402
from socialaff_sim.inference.protocol import Prediction, observed_part  # noqa: E402
from socialaff_sim.inference import BodyFitter, SynthesisConfig, synthesize  # noqa: E402
from socialaff_sim.learning.config import LearningConfig  # noqa: E402
from socialaff_sim.learning import SocialAffordanceModel  # noqa: E402


MODES = {"offline": SynthesisConfig.offline, "reactive": SynthesisConfig.reactive, "paper": SynthesisConfig}
"""The synthesis settings measured: as ``evaluate`` runs the model, as the simulator does, and the paper's."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--iterations", type=int, default=100, help="outer MCMC iterations of the fitted models")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--interactions", nargs="*", default=list(INTERACTIONS))
    parser.add_argument("--synthesis", default=",".join(MODES), help=f"comma-separated modes of {', '.join(MODES)}")
    parser.add_argument("--json", default=None, help="also write the table here (atomically)")
    args = parser.parse_args()
    modes = [m for m in args.synthesis.split(",") if m]
    unknown = [m for m in modes if m not in MODES]
    if unknown or not modes:
        parser.error(f"--synthesis: unknown mode(s) {unknown}; choose from {', '.join(MODES)}")
    data = generate_dataset(args.seed)
    models = {}
    for label in args.interactions:  # one fit per interaction serves every mode
        train = list(data.of_label(label))[:18]
        rng = np.random.default_rng(args.seed)
        model = SocialAffordanceModel(learning=LearningConfig(iterations=args.iterations)).fit(train, rng=rng)
        models[label] = (model, BodyFitter().fit_interactions(train, agent=1, rng=rng))
    result: dict = {"seed": args.seed, "iterations": args.iterations, "n_observed": SynthesisConfig().n_observed,
                    "seconds_clock": "wall (time.perf_counter)", "modes": {}}
    for mode in modes:
        cfg = MODES[mode]()
        print(f"[{mode}]")
        print(f"{'interaction':<14}{'frames':>8}{'seconds':>9}{'frames/s':>10}{'key err m':>11}{'+skeleton f/s':>15}")
        total_frames = total_secs = 0.0
        rows: dict[str, dict] = {}
        for label, (model, body) in models.items():
            test = list(data.of_label(label))[18:]
            frames, secs = _timed(model, test, cfg, None)
            _, secs_body, errs = _timed(model, test, cfg, body, errors=True)
            total_frames += frames
            total_secs += secs
            print(f"{label:<14}{frames:>8}{secs:>9.2f}{frames / secs:>10.0f}{np.mean(errs):>11.3f}{frames / secs_body:>15.0f}",
                  flush=True)
            rows[label] = {"test_instances": len(test), "frames": frames, "seconds": secs, "frames_per_s": frames / secs,
                           "key_joint_error_m": float(np.mean(errs)), "frames_per_s_with_skeleton": frames / secs_body}
        print(f"{'all':<14}{int(total_frames):>8}{total_secs:>9.2f}{total_frames / total_secs:>10.0f}")
        result["modes"][mode] = {"interactions": rows, "all": {"frames": int(total_frames), "seconds": total_secs,
                                                               "frames_per_s": total_frames / total_secs}}
    if args.json:
        atomic_write_text(args.json, json.dumps(result, indent=2))


def _timed(model, test, cfg, body, errors=False):  # noqa: ANN001, ANN202
    """Synthesize every test instance: (synthesized frames, wall seconds[, key-joint errors])."""
    frames, errs = 0, []
    start = time.perf_counter()
    for k, inter in enumerate(test):
        keys, skel, subs, _ = synthesize(
            model, observed_part(inter, cfg.n_observed), rng=np.random.default_rng(k), body=body, config=cfg
        )
        frames += inter.n_frames - cfg.n_observed
        if errors:
            pred = Prediction(joints=skel, key_joints=keys, subevents=subs, n_observed=cfg.n_observed)
            errs.append(key_joint_error(pred, inter))
    secs = time.perf_counter() - start
    return (frames, secs, errs) if errors else (frames, secs)


if __name__ == "__main__":
    main()
