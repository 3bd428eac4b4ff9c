"""CPU of one physics step of the balance controller, from a saved mid-episode state, robust to a loaded machine.

For each case (robot, interaction, instance of the synthetic set, seed 0) a Simulator in ``SimConfig.standing()``
replays the ground truth up to ``--at`` of the episode's frames (then on to the first frame the controller drives),
its ``MjData`` is saved, and ``BalanceController.step`` is called ``--calls`` times, the state restored before each
call; printed per case: the frame, the share of calls the controller drove, and the process CPU per call (ms:
minimum, 10th percentile, median). ``--balance FIELD=VALUE ...`` replaces fields of the standing mode's
``BalanceConfig`` (e.g. ``"qp_kernel='numba'"``). Alternate runs of two code trees and compare their minima::

    OMP_NUM_THREADS=1 PYTHONPATH=/path/to/tree python scripts/bench_balance_step.py --calls 400 \\
        --mjcf unitree_h1=../shared/robots/unitree_h1/h1.xml

The library never imports this script.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time

import mujoco
import numpy as np

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.balance_config import BalanceConfig
from socialaff_sim.sim.simulator import SimConfig, Simulator

from _config_flags import field_settings  # (scripts/, sys.path[0])

CASES = [("ours", "shake_hands", 1), ("ours", "pull_up", 0), ("unitree_h1", "hand_over", 0)]


class _Stop(Exception):
    pass


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--calls", type=int, default=400, help="controller steps timed per case")
    ap.add_argument("--at", type=float, default=0.6, help="fraction of the episode's frames before the state is saved")
    ap.add_argument("--mjcf", nargs="*", default=[], help="NAME=PATH: the MJCF of a robot the project does not ship")
    ap.add_argument("--balance", nargs="+", default=[], metavar="FIELD=VALUE",
                    help="BalanceConfig fields replaced in SimConfig.standing() (e.g. \"qp_kernel='numba'\")")
    args = ap.parse_args()
    cfg = SimConfig.standing()
    changes = field_settings(ap, "--balance", BalanceConfig, args.balance)
    if changes:
        cfg = dataclasses.replace(cfg, balance=dataclasses.replace(cfg.balance, **changes))
    paths = dict(item.split("=", 1) for item in args.mjcf)
    data = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=8))
    out = {}
    for robot, label, k in CASES:
        if robot != "ours" and robot not in paths:
            continue
        inter = list(data.of_label(label))[k]
        sim = Simulator(load_robot(robot, mjcf=paths.get(robot)), label, cfg)
        stop = int(args.at * inter.n_frames)

        def on_frame(s: Simulator, _r: object, _x: object, stop: int = stop) -> None:
            if s.frame >= stop and s._stage.stepper.balance.active:  # type: ignore[union-attr]
                raise _Stop

        try:
            run_episode(sim, GroundTruthSource(), inter, on_frame=on_frame)
        except _Stop:
            pass
        stepper = sim._stage.stepper  # type: ignore[union-attr]
        m, d, bal = sim.scene.model, sim.data, stepper.balance
        q, qd = stepper._qs[-1].copy(), stepper._hinge_vel.copy()
        saved = mujoco.MjData(m)
        mujoco.mj_copyData(saved, m, d)
        times, active = [], 0
        for _ in range(args.calls):
            mujoco.mj_copyData(d, m, saved)
            tic = time.process_time()
            bal.step(m, d, q, qd)
            times.append(time.process_time() - tic)
            active += bal.active
        t = 1e3 * np.array(times)
        out[f"{robot}/{label}/{k}"] = {"frame": sim.frame, "active": active / args.calls, "ms_min": float(t.min()),
                                       "ms_p10": float(np.percentile(t, 10)), "ms_median": float(np.median(t))}
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
