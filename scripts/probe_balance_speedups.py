"""Two speed-ups of the standing mode's balance step that change its outputs, measured (issue 25); neither is adopted.

The standing mode's controller spends about a seventh of a driven physics step in DAQP and most of the rest in
the Python and NumPy work around the QP (docs/benchmarks.md). Cuts that keep every output bit are in the library; what
is left needs a changed computation. This script measures two, on episodes of the synthetic set (seed 0, ground
truth, ``SimConfig.standing()``), by replacing a library function in this process only:

* ``--probe warm``: DAQP warm-started from the previous call's solution (``primal_start``), *open loop*: every QP
  is solved cold (as the library does, whose solution drives the robot) and warm; per episode the median process
  CPU of either solve, DAQP's mean iterations and the largest difference of the two solutions (over the calls
  both solved; the solution vector is in m/s²);
* ``--probe half``: the balance QP solved at every ``--every``-th driven physics step only, its torques held in
  between (the servo commands are still recomputed from them at each step's state); every episode is run with
  ``--every 1`` (today) and with the given value, and printed per episode: process CPU, success, catches, the
  episode's and the contact phase's outside support and the failures triggered.

One JSON line per episode::

    OMP_NUM_THREADS=1 python scripts/probe_balance_speedups.py --probe warm
    OMP_NUM_THREADS=1 python scripts/probe_balance_speedups.py --probe half --every 2 \\
        --mjcf unitree_h1=../shared/robots/unitree_h1/h1.xml

The library never imports this script.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import types
from pathlib import Path
from typing import Any

import daqp
import numpy as np

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.retarget.robot import load_robot
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim import balance_control, contact_qp
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.simulator import SimConfig, Simulator

LABELS = ("hand_over", "high_five", "pull_up", "shake_hands", "throw_catch")


def _episode(robot: str, path: str | None, label: str, inter: Any) -> tuple[dict, float, Simulator]:
    sim = Simulator(load_robot(robot, mjcf=path), label, SimConfig.standing())
    tic = time.process_time()
    met = run_episode(sim, GroundTruthSource(), inter)
    return met, time.process_time() - tic, sim


def _warm(robot: str, path: str | None, label: str, inter: Any) -> dict:
    calls: list[tuple[float, float, int, int, float, bool]] = []
    prev: list[np.ndarray] = []

    def solve(H, f, A, bu, bl, sn):  # contact_qp's call only: mink's IK keeps the real module
        tic = time.process_time()
        cold = daqp.solve(H, f, A, bu, bl, sn)
        t_cold = time.process_time() - tic
        start = {"primal_start": prev[-1]} if prev and len(prev[-1]) == len(f) else {}
        tic = time.process_time()
        warm = daqp.solve(H, f, A, bu, bl, sn, **start)
        t_warm = time.process_time() - tic
        solved = cold[2] > 0 and warm[2] > 0
        calls.append((t_cold, t_warm, cold[3]["iterations"], warm[3]["iterations"],
                      float(np.max(np.abs(np.asarray(warm[0]) - np.asarray(cold[0])))) if solved else 0.0, solved))
        prev.append(np.asarray(cold[0]).copy())
        return cold

    contact_qp.daqp = types.SimpleNamespace(solve=solve)
    try:
        met, _, _ = _episode(robot, path, label, inter)
    finally:
        contact_qp.daqp = daqp
    c = np.array(calls)
    return {"calls": len(c), "cold_ms_median": 1e3 * float(np.median(c[:, 0])),
            "warm_ms_median": 1e3 * float(np.median(c[:, 1])), "iterations_cold": float(c[:, 2].mean()),
            "iterations_warm": float(c[:, 3].mean()), "unsolved_calls": int((c[:, 5] == 0).sum()),
            "largest_difference": float(c[:, 4].max()), "success": met["success"]}


def _half(robot: str, path: str | None, label: str, inter: Any, every: int) -> dict:
    real = balance_control.BalanceController._torques
    out = {}
    for k in (1, every):
        def held(self, *a, _k=k):  # type: ignore[no-untyped-def]
            n = self.__dict__.get("_probe_n", 0)
            self._probe_n = n + 1
            if n % _k == 0 or "_probe_tau" not in self.__dict__:
                self._probe_tau = real(self, *a)
            return self._probe_tau

        balance_control.BalanceController._torques = held  # type: ignore[method-assign]
        try:
            met, cpu, sim = _episode(robot, path, label, inter)
        finally:
            balance_control.BalanceController._torques = real  # type: ignore[method-assign]
        sup = met["support"]
        out[f"every_{k}"] = {"cpu_s": cpu, "success": met["success"],
                             "catches": sim._stage.stepper.balance.harness.catches,  # type: ignore[union-attr]
                             "outside": sup["episode"]["outside_support_mean"],
                             "outside_contact": (sup.get("contact_phase") or {}).get("outside_support_mean"),
                             "failed": [f["kind"] for f in met["failures"] if f["triggered"]]}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--probe", choices=["warm", "half"], required=True)
    ap.add_argument("--every", type=int, default=2, help="half: the QP at every k-th driven step (k >= 2)")
    ap.add_argument("--instances", type=int, default=2, help="instances per interaction (000 on)")
    ap.add_argument("--mjcf", nargs="*", default=[], help="NAME=PATH: the MJCF of a robot the project does not ship")
    args = ap.parse_args()
    if args.every < 2:
        ap.error("--every: expected an integer >= 2")
    if args.instances < 1:
        ap.error("--instances: expected an integer >= 1")
    try:
        paths = dict(item.split("=", 1) for item in args.mjcf)
    except ValueError:
        ap.error("--mjcf: expected NAME=PATH")
    for name, path in paths.items():
        if not Path(path).is_file():
            ap.error(f"--mjcf {name}: no file {path}")
    data = generate_dataset(seed=0, config=SyntheticConfig(instances_per_interaction=args.instances))
    for robot in ["ours", *paths]:
        for label in LABELS:
            for i, inter in enumerate(data.of_label(label)):
                row = (_warm(robot, paths.get(robot), label, inter) if args.probe == "warm"
                       else _half(robot, paths.get(robot), label, inter, args.every))
                print(json.dumps({"robot": robot, "interaction": label, "instance": i, **row}), flush=True)
    sys.stdout.flush()


if __name__ == "__main__":
    main()
