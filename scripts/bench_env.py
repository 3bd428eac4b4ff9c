"""Benchmark the Gymnasium environment against Gymnasium's Humanoid-v5, side by side in one process.

Three environments are built in one process and stepped in interleaved rounds (the order rotates every
round), so that whatever load the machine carries falls on all of them alike; the ratios are what count:

* ``ours_zero``: the default environment (``socialaff_sim/SocialAffordance-v0``) in ``residual`` mode with
  zero residuals (the robot follows the adapter's proposal): the typical per-step cost;
* ``ours_random``: the default environment as registered (``targets`` mode) with uniformly random
  actions, resets included (episodes end early on failures, so resets weigh);
* ``humanoid``: Gymnasium's ``Humanoid-v5`` with uniformly random actions, resets included.

Each gets ``--steps`` steps per round. Reported per environment: steps/s (wall and CPU time, with and
without the resets), ms per reset (median and 95th percentile, warm: every instance was reset once
before timing; the cold first resets, with the scene compilation, are reported apart), and per round the
ratio of ours to Humanoid-v5 (median over rounds, and the ratio of the totals). Then one more pass per
policy of ours with every stage timed (exclusive time: a stage's own, its callees' in their own stages):
synthesis (the adapter's proposal and belief), retargeting (key-joint scaling), IK (mink), physics
(``mujoco.mj_step`` and the sub-step loop around it), scoring (contacts, support, sub-goals, reward),
observation (observation and info), reset, and the rest. ``--vector 1,2,4,8`` adds
``gymnasium.make_vec`` (async) throughput per worker count, ours and Humanoid-v5.

Run on one core::

    OMP_NUM_THREADS=1 python scripts/bench_env.py --rounds 5 --steps 600 --vector 1,2,4,8 --json env.json

Besides steps per second, the simulated seconds per CPU second (ours: ``info["time"]``; Humanoid-v5: its
``dt`` of 0.015 s per step) and their ratio, so that a ratio of steps cannot be won by simulating less per step.
``--control-dt`` sets our env's control period (``default``: the env's own, 0.015 s; ``none``: one step per
data frame; or seconds).

``--profile`` prints a cProfile of the ``ours_zero`` pass (cProfile inflates the Python parts).
``--compliant-person 0``, ``--timestep S`` and ``--ik-iterations N`` replace those fields of the preset's
``SimConfig`` for ``ours_zero`` and ``ours_random`` (the speed options of docs/environment.md; their cost in
fidelity is measured by scripts/bench_env_fidelity.py). ``--balance FIELD=VALUE ...`` changes the balance
controller's settings (with ``--sim-mode standing``) of ``ours_zero`` and ``ours_random``, and adds a fourth
environment, ``ours_zero_off``, the zero-residual env without them, stepped in the same interleaved rounds:
``option_speedup`` is the median over rounds of ``ours_zero``'s rate over ``ours_zero_off``'s (a paired measure of
the option's gain, the load falling on both alike).
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo is imported (dm_control probes a GL backend)

import argparse  # noqa: E402
import cProfile  # noqa: E402
import dataclasses  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import pstats  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from dataclasses import dataclass, field  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import socialaff_sim  # noqa: E402,F401  (registers the ids)
from socialaff_sim._atomic import atomic_write_text  # noqa: E402
from socialaff_sim.environment import physics_config  # noqa: E402
from socialaff_sim.sim.simulator import SimConfig  # noqa: E402

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:  # run as `python scripts/bench_env.py` it is sys.path[0]; the tests load this file by path
    sys.path.append(_HERE)
from _env_stages import STAGES, StageTimer, instrument  # noqa: E402
from _config_flags import field_settings  # noqa: E402
from socialaff_sim.sim.balance_config import BalanceConfig  # noqa: E402

ENV_ID = "socialaff_sim/SocialAffordance-v0"
REFERENCE_ID = "Humanoid-v5"


@dataclass
class Runner:
    """One environment, its policy and its running totals; episodes carry over between rounds."""

    name: str
    env: gym.Env
    policy: str  # "zero" | "random"
    seed: int
    steps: int = 0
    resets: int = 0
    step_wall: float = 0.0
    step_cpu: float = 0.0
    reset_wall: list[float] = field(default_factory=list)
    reset_cpu: list[float] = field(default_factory=list)
    finished: int = 0
    successes: int = 0
    sim_seconds: float = 0.0  # simulated time the timed steps covered
    rounds: list[float] = field(default_factory=list)  # steps/s (wall, resets included) per round
    rounds_cpu: list[float] = field(default_factory=list)  # steps per CPU s (resets included) per round
    _rng: np.random.Generator = field(init=False)
    _zero: np.ndarray = field(init=False)
    _live: bool = False
    _clock: float = 0.0  # ours: info["time"] after the last step (simulated seconds since the reset)

    def __post_init__(self) -> None:
        self._rng = np.random.default_rng(self.seed)
        self.env.action_space.seed(self.seed)
        self._zero = np.zeros(self.env.action_space.shape, self.env.action_space.dtype)

    def _reset(self) -> None:
        c, w = time.process_time(), time.perf_counter()
        self.env.reset(seed=int(self._rng.integers(1 << 31)))
        self.reset_wall.append(time.perf_counter() - w)
        self.reset_cpu.append(time.process_time() - c)
        self.resets += 1
        self._live = True
        self._clock = 0.0

    def run(self, n: int) -> None:
        """``n`` steps, resetting whenever an episode ends (the resets are timed apart)."""
        wall0 = self.step_wall + sum(self.reset_wall)
        cpu0 = self.step_cpu + sum(self.reset_cpu)
        sample = self.env.action_space.sample
        for _ in range(n):
            if not self._live:
                self._reset()
            a = self._zero if self.policy == "zero" else sample()
            c, w = time.process_time(), time.perf_counter()
            _, _, term, trunc, info = self.env.step(a)
            self.step_wall += time.perf_counter() - w
            self.step_cpu += time.process_time() - c
            self.steps += 1
            if "time" in info:  # ours: the simulated time since the reset (a step covers a control period)
                self.sim_seconds += info["time"] - self._clock
                self._clock = info["time"]
            else:  # Humanoid-v5: a fixed dt (5 physics steps of 3 ms)
                self.sim_seconds += float(self.env.unwrapped.dt)
            if term or trunc:
                self._live = False
                self.finished += 1
                self.successes += bool(info.get("success", False))
        self.rounds.append(n / (self.step_wall + sum(self.reset_wall) - wall0))
        self.rounds_cpu.append(n / (self.step_cpu + sum(self.reset_cpu) - cpu0))

    def summary(self) -> dict[str, Any]:
        rw = np.array(self.reset_wall) * 1e3
        return {
            "policy": self.policy, "steps": self.steps, "resets": self.resets, "episodes_finished": self.finished,
            "success_rate": self.successes / self.finished if self.finished else None,
            "steps_per_s_wall": self.steps / self.step_wall,
            "steps_per_s_wall_with_resets": self.steps / (self.step_wall + rw.sum() / 1e3),
            "steps_per_s_cpu": self.steps / self.step_cpu,
            "steps_per_s_cpu_with_resets": self.steps / (self.step_cpu + sum(self.reset_cpu)),
            "sim_seconds": self.sim_seconds,
            "sim_seconds_per_step": self.sim_seconds / self.steps if self.steps else None,
            "sim_s_per_cpu_s_with_resets": self.sim_seconds / (self.step_cpu + sum(self.reset_cpu)),
            "ms_per_reset_cpu_median": float(np.median(self.reset_cpu)) * 1e3 if self.reset_cpu else None,
            "ms_per_reset_median": float(np.median(rw)) if len(rw) else None,
            "ms_per_reset_p95": float(np.percentile(rw, 95)) if len(rw) else None,
            "ms_per_reset_mean": float(rw.mean()) if len(rw) else None,
            "steps_per_s_per_round": self.rounds,
        }


def sim_options(physics: str, compliant_person: int | None, timestep: float | None,
                ik_iterations: int | None, sim_mode: str = "preset") -> SimConfig | None:
    """The preset's simulator settings with the given fields replaced (``None``: the preset as it is);
    ``sim_mode`` ``harness`` or ``standing``: the foot lock, stance, balance and floor time constant fields of
    ``SimConfig.harness()`` or ``SimConfig.standing()`` instead of the preset's."""
    if compliant_person is None and timestep is None and ik_iterations is None and sim_mode == "preset":
        return None
    cfg = physics_config(physics)
    if sim_mode != "preset":
        named = SimConfig.harness() if sim_mode == "harness" else SimConfig.standing()
        cfg = dataclasses.replace(cfg, foot_lock=named.foot_lock, stance=named.stance, balance=named.balance,
                                  floor_time_constant=named.floor_time_constant)
    if compliant_person is not None:
        cfg = dataclasses.replace(cfg, compliant_person=bool(compliant_person))
    if timestep is not None:
        cfg = dataclasses.replace(cfg, timestep=timestep)
    if ik_iterations is not None:
        cfg = dataclasses.replace(cfg, ik=dataclasses.replace(cfg.ik, iterations=ik_iterations))
    return cfg


def control_kwargs(control_dt: str) -> dict[str, Any]:
    """``--control-dt``: ``default`` (the env's own), ``none`` (one env step per data frame) or seconds."""
    if control_dt == "default":
        return {}
    return {"control_dt": None if control_dt == "none" else float(control_dt)}


def make_ours(policy: str, robot: str, physics: str, sim_config: SimConfig | None = None,
              control: dict[str, Any] | None = None) -> gym.Env:
    mode = "residual" if policy == "zero" else "targets"
    return gym.make(ENV_ID, action_mode=mode, robot=robot, physics=physics, sim_config=sim_config, **(control or {}))


def warm_up(env: gym.Env) -> list[float]:
    """Reset every instance of the env once (compiling each task's scene, caching each instance's reset);
    the wall time of each of these cold resets, ms."""
    out = []
    for inter in env.unwrapped.pool.instances:
        w = time.perf_counter()
        env.reset(seed=0, options={"instance": inter.instance_id})
        out.append(1e3 * (time.perf_counter() - w))
    return out


# --------------------------------------------------------------------------- stage timing
def stage_pass(runner: Runner, n: int) -> dict[str, Any]:
    """``n`` steps of ``runner`` with every stage timed (scripts/_env_stages.py): ms per step per stage, and shares."""
    timer = StageTimer()
    instrument(timer)
    try:
        w = time.perf_counter()
        runner.run(n)
        wall = time.perf_counter() - w
    finally:
        timer.restore()
    runner.rounds.pop()  # this pass is not a timing round
    runner.rounds_cpu.pop()
    ms = {s: 1e3 * timer.seconds.get(s, 0.0) / n for s in STAGES}
    return {"steps": n, "ms_per_step": ms, "ms_per_step_total": 1e3 * wall / n,
            "share": {s: 1e-3 * v * n / wall for s, v in ms.items()}}


# --------------------------------------------------------------------------- vector envs
def vector_rate(make: Callable[[], gym.vector.VectorEnv], n_envs: int, total_steps: int, policy: str, seed: int,
                ours: bool) -> dict[str, float]:
    """Env steps per second (wall) of an async vector env over ``total_steps`` env steps after a warm-up."""
    venv = make()
    try:
        if ours:  # every worker compiles every scene and caches every instance before timing
            venv.call("warm_up")
        venv.reset(seed=seed)
        venv.action_space.seed(seed)
        zero = np.zeros(venv.action_space.shape, venv.action_space.dtype)
        for _ in range(5):
            venv.step(zero if policy == "zero" else venv.action_space.sample())
        n = max(1, total_steps // n_envs)
        w, c = time.perf_counter(), time.process_time()
        for _ in range(n):
            venv.step(zero if policy == "zero" else venv.action_space.sample())
        wall = time.perf_counter() - w
        return {"workers": n_envs, "env_steps": n * n_envs, "steps_per_s_wall": n * n_envs / wall,
                "parent_cpu_s": time.process_time() - c}
    finally:
        venv.close()


def vector_table(workers: list[int], steps: int, robot: str, physics: str, seed: int,
                 control: dict[str, Any]) -> list[dict[str, Any]]:
    rows = []
    for n in workers:
        row: dict[str, Any] = {"workers": n}
        for key, policy, ours in (("humanoid", "random", False), ("ours_zero", "zero", True),
                                  ("ours_random", "random", True)):
            if ours:
                mode = "residual" if policy == "zero" else "targets"

                def make(n: int = n, mode: str = mode) -> gym.vector.VectorEnv:
                    return gym.make_vec(ENV_ID, num_envs=n, vectorization_mode="async", action_mode=mode,
                                        robot=robot, physics=physics, **control)
            else:
                def make(n: int = n) -> gym.vector.VectorEnv:
                    return gym.make_vec(REFERENCE_ID, num_envs=n, vectorization_mode="async")
            row[key] = vector_rate(make, n, steps, policy, seed, ours)["steps_per_s_wall"]
        row["ratio_zero"] = row["ours_zero"] / row["humanoid"]
        row["ratio_random"] = row["ours_random"] / row["humanoid"]
        rows.append(row)
    return rows


# --------------------------------------------------------------------------- main
def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--robot", default="ours", help="ours | cmu | mapping .toml (our env)")
    ap.add_argument("--physics", default="fast", choices=["fast", "accurate"])
    ap.add_argument("--steps", type=int, default=600, help="steps per environment per round")
    ap.add_argument("--rounds", type=int, default=5, help="interleaved rounds")
    ap.add_argument("--stage-steps", type=int, default=600, help="steps of each timed-stage pass (0: none)")
    ap.add_argument("--vector", default="", help="worker counts for make_vec (async), e.g. 1,2,4,8 (empty: none)")
    ap.add_argument("--vector-steps", type=int, default=1600, help="env steps per vector measurement")
    ap.add_argument("--compliant-person", type=int, choices=[0, 1], default=None,
                    help="override SimConfig.compliant_person of the preset (ours_zero/ours_random, not --vector)")
    ap.add_argument("--timestep", type=float, default=None, help="override SimConfig.timestep of the preset, s")
    ap.add_argument("--ik-iterations", type=int, default=None, help="override IKConfig.iterations of the preset")
    ap.add_argument("--control-dt", default="default",
                    help="our env's control period: default (the env's), none (one step per data frame) or seconds")
    ap.add_argument("--sim-mode", default="preset", choices=["preset", "harness", "standing"],
                    help="the physics mode of our env: the preset's own, or SimConfig.harness()'s / .standing()'s "
                         "foot lock, stance, balance and floor time constant fields (issue 25)")
    ap.add_argument("--balance", nargs="+", default=[], metavar="FIELD=VALUE",
                    help="BalanceConfig fields for ours_zero/ours_random (needs --sim-mode standing); adds ours_zero_off")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--profile", action="store_true", help="print a cProfile of one ours_zero pass")
    ap.add_argument("--json", default=None, help="also write the result here")
    args = ap.parse_args()

    load0 = os.getloadavg()
    t0 = time.perf_counter()
    options = sim_options(args.physics, args.compliant_person, args.timestep, args.ik_iterations, args.sim_mode)
    control = control_kwargs(args.control_dt)
    changes = field_settings(ap, "--balance", BalanceConfig, args.balance)
    off = options
    if changes:
        if options is None or options.balance is None:
            ap.error("--balance: needs --sim-mode standing (a balance controller)")
        options = dataclasses.replace(options, balance=dataclasses.replace(options.balance, **changes))
    runners = [
        Runner("ours_zero", make_ours("zero", args.robot, args.physics, options, control), "zero", args.seed),
        Runner("ours_random", make_ours("random", args.robot, args.physics, options, control), "random",
               args.seed + 1),
        Runner("humanoid", gym.make(REFERENCE_ID), "random", args.seed + 2),
    ]
    if changes:  # the same zero-residual env without the changes, in the same rounds
        runners.append(Runner("ours_zero_off", make_ours("zero", args.robot, args.physics, off, control), "zero",
                              args.seed))
    ours = [r for r in runners if r.name != "humanoid"]
    cold = {r.name: warm_up(r.env) for r in ours}
    for r in runners:  # a few steps each, outside the timing
        r.run(20)
        r.rounds.clear()
        r.rounds_cpu.clear()
    for k in range(args.rounds):
        order = runners[k % len(runners):] + runners[: k % len(runners)]
        for r in order:
            r.run(args.steps)
    ref = runners[2]
    res: dict[str, Any] = {"env_id": ENV_ID, "reference_id": REFERENCE_ID, "robot": args.robot,
                           "physics": args.physics, "sim_options": {"compliant_person": args.compliant_person,
                           "timestep": args.timestep, "ik_iterations": args.ik_iterations,
                           "sim_mode": args.sim_mode, "balance": changes},
                           "control_dt": runners[0].env.unwrapped.config.control_dt,
                           "rounds": args.rounds, "steps_per_round": args.steps,
                           "omp_num_threads": os.environ.get("OMP_NUM_THREADS"), "cpus": os.cpu_count(),
                           "machine": platform.processor() or platform.machine(),
                           "instances": len(runners[0].env.unwrapped.pool.instances)}
    for r in runners:
        res[r.name] = r.summary()
    for r in ours:
        per_round = [a / b for a, b in zip(r.rounds, ref.rounds, strict=True)]
        res[r.name]["ratio_per_round"] = per_round
        res[r.name]["ratio_median"] = float(np.median(per_round))
        res[r.name]["ratio_cpu_median"] = float(np.median([a / b for a, b in zip(r.rounds_cpu, ref.rounds_cpu,
                                                                                  strict=True)]))
        res[r.name]["ratio_of_totals"] = (res[r.name]["steps_per_s_wall_with_resets"]
                                          / res["humanoid"]["steps_per_s_wall_with_resets"])
        res[r.name]["ratio_of_totals_without_resets"] = (res[r.name]["steps_per_s_wall"]
                                                         / res["humanoid"]["steps_per_s_wall_with_resets"])
        res[r.name]["ratio_cpu"] = (res[r.name]["steps_per_s_cpu_with_resets"]
                                    / res["humanoid"]["steps_per_s_cpu_with_resets"])
        res[r.name]["ratio_sim_seconds_cpu"] = (res[r.name]["sim_s_per_cpu_s_with_resets"]
                                                / res["humanoid"]["sim_s_per_cpu_s_with_resets"])
        res[r.name]["cold_reset_ms"] = {"first_per_task_max": max(cold[r.name]),
                                        "median": float(np.median(cold[r.name]))}
    if changes:
        res["option_speedup_per_round"] = [a / b for a, b in zip(runners[0].rounds, runners[3].rounds, strict=True)]
        res["option_speedup"] = float(np.median(res["option_speedup_per_round"]))
        res["option_speedup_cpu_per_round"] = [a / b for a, b in zip(runners[0].rounds_cpu, runners[3].rounds_cpu,
                                                                      strict=True)]
        res["option_speedup_cpu"] = float(np.median(res["option_speedup_cpu_per_round"]))
    if args.stage_steps:
        res["stages"] = {r.name: stage_pass(r, args.stage_steps) for r in runners[:2]}
    if args.profile:
        prof = cProfile.Profile()
        prof.enable()
        runners[0].run(args.steps)
        prof.disable()
        out = io.StringIO()
        pstats.Stats(prof, stream=out).sort_stats("tottime").print_stats(30)
        res["profile_top"] = out.getvalue()
    for r in runners:
        r.env.close()
    if args.vector:
        res["vector"] = vector_table([int(x) for x in args.vector.split(",")], args.vector_steps, args.robot,
                                     args.physics, args.seed, control)
    res["wall_seconds"] = time.perf_counter() - t0
    res["load_average_before"], res["load_average_after"] = load0, os.getloadavg()
    profile = res.pop("profile_top", None)
    text = json.dumps(res, indent=2)
    print(text)
    if profile:
        print(profile)
    if args.json:
        atomic_write_text(args.json, text)


if __name__ == "__main__":
    main()
