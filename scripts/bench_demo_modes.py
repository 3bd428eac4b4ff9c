"""The demo's five simulated reactions in each physics mode, from the models a demo run saved (issue 25).

``socialaff-sim demo --out DIR`` saves each interaction's model (``DIR/<label>_model.npz``) and simulates its first
held-out instance. This script simulates that same instance with that model, causally as the demo does
(``ModelSource(model, seed, SynthesisConfig.reactive())``), once per physics mode (``SimConfig.mode``:
``harness``, ``standing``), and prints per interaction and mode: sub-goals met, failures, and over the contact
phase (frames where a sub-goal's contact holds now) the outside support (mean and peak, % of the weight), the
frames with the harness off, the feet's slide path and drift (cm), the torso's largest tilt and the CPU time
(``--balance FIELD=VALUE ...``: the standing mode's controller changed; ``--completion FIELD=VALUE ...``: the
contact completion's settings changed in every mode; ``--foot-lock FIELD=VALUE ...``: the standing mode's foot
lock changed; ``--labels``: only these interactions; ``--robot NAME --mjcf PATH``: a robot the project does not
ship)::

    OMP_NUM_THREADS=1 python scripts/bench_demo_modes.py --demo demo_out --json modes.json
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

from socialaff_sim._atomic import atomic_write_text
from socialaff_sim.data.synthetic import INTERACTIONS, generate_dataset
from socialaff_sim.demo.pipeline import DemoConfig, held_out
from socialaff_sim.inference import SynthesisConfig
from socialaff_sim.learning.estimator import SocialAffordanceModel
from socialaff_sim.retarget.contact_completion import ContactCompletionConfig
from socialaff_sim.retarget.model_source import ModelSource
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.footlock import FootLockConfig
from socialaff_sim.sim.sim_config import PHYSICS_MODES
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.tasks import task_for_label

from _config_flags import field_settings  # scripts/ (sys.path[0])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--demo", required=True, help="a demo's output folder (its <label>_model.npz files)")
    p.add_argument("--modes", nargs="+", default=list(PHYSICS_MODES), choices=PHYSICS_MODES)
    p.add_argument("--seed", type=int, default=DemoConfig().seed, help="the demo's seed (default: the demo's)")
    p.add_argument("--robot", default="ours")
    p.add_argument("--mjcf", help="the robot's MJCF file, for a robot the project does not ship (e.g. unitree_h1)")
    p.add_argument("--json", help="write the figures here")
    p.add_argument("--balance", nargs="*", default=[], metavar="FIELD=VALUE",
                   help="BalanceConfig fields for the standing mode (Python literals), e.g. hand_yield=0.5")
    p.add_argument("--completion", nargs="*", default=[], metavar="FIELD=VALUE",
                   help="ContactCompletionConfig fields for every mode (Python literals), e.g. reach_band=0.15")
    p.add_argument("--foot-lock", nargs="*", default=[], metavar="FIELD=VALUE",
                   help="FootLockConfig fields for the standing mode (Python literals), e.g. hold_lift=0.08")
    p.add_argument("--labels", nargs="*", help="only these interactions")
    args = p.parse_args()
    over = field_settings(p, "--balance", BalanceConfig, args.balance)
    completion = field_settings(p, "--completion", ContactCompletionConfig, args.completion)
    lock = field_settings(p, "--foot-lock", FootLockConfig, args.foot_lock)
    robot = load_robot(args.robot, mjcf=args.mjcf)
    data = generate_dataset(args.seed)
    rows = []
    for label in INTERACTIONS:
        model_path = Path(args.demo) / f"{label}_model.npz"
        if not model_path.exists() or (args.labels and label not in args.labels):
            continue
        model = SocialAffordanceModel.load(model_path)
        _, test = held_out(list(data.of_label(label)), DemoConfig().n_test)
        shown = test[0]
        for mode in args.modes:
            source = ModelSource(model, seed=args.seed, config=SynthesisConfig.reactive())
            tic = time.process_time()
            physics = SimConfig.mode(mode)
            if over and physics.balance is not None:
                physics = dataclasses.replace(physics, balance=dataclasses.replace(physics.balance, **over))
            if lock and mode == "standing":
                physics = dataclasses.replace(physics, foot_lock=dataclasses.replace(physics.foot_lock, **lock))
            if completion and physics.contact_completion is not None:
                physics = dataclasses.replace(
                    physics, contact_completion=dataclasses.replace(physics.contact_completion, **completion))
            m = run_episode(Simulator(robot, task_for_label(label), physics), source, shown)
            cp = m["support"]["contact_phase"]
            rows.append({"label": label, "instance": shown.instance_id, "mode": mode, "success": m["success"],
                         "subgoals": {g["name"]: g["success"] for g in m["subgoals"]},
                         "failures": [f["kind"] for f in m["failures"] if f["triggered"]],
                         "cpu_seconds": time.process_time() - tic, "support_mode": m["support"]["mode"], **cp})
    print(f"{'interaction':<13}{'mode':<10}{'ok':>4}{'frames':>8}{'support':>9}{'peak':>7}{'off':>6}{'slide':>7}"
          f"{'drift':>7}{'tilt':>7}{'cpu s':>7}  failures")
    for r in rows:
        have = bool(r["frames"])

        def pct(k: str, r: dict = r, have: bool = have) -> str:
            return f"{100 * r[k]:.1f}" if have else "-"

        def num(k: str, r: dict = r, have: bool = have) -> str:
            return f"{r[k]:.1f}" if have else "-"

        print(f"{r['label']:<13}{r['mode']:<10}{'yes' if r['success'] else 'no':>4}{r['frames']:>8}"
              f"{pct('outside_support_mean'):>8}%{pct('outside_support_peak'):>6}%{r['released_frames']:>6}"
              f"{num('foot_slide_cm'):>7}{num('foot_drift_cm'):>7}{num('torso_tilt_deg_max'):>7}"
              f"{r['cpu_seconds']:>7.1f}  {', '.join(r['failures']) or 'none'}")
    if args.json:
        atomic_write_text(args.json, json.dumps({"config": vars(args), "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
