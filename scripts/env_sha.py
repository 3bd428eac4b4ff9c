"""A SHA-256 of what the environment gives a policy, to show that a change of code changes no result.

Plays ``--steps`` steps per policy (``targets``: seeded random targets; ``residual``: seeded random residuals;
``zero``: zero residuals, the action held through every frame; resetting with seeded draws after every end) in the default environment and hashes, step
by step, every observation entry (in :data:`~socialaff_sim.environment.observation.OBSERVATION_KEYS` order,
float32 bytes), the reward and every ``info["reward_<term>"]`` (float64 bytes), the termination flags and the
termination reason. Run it on two code trees and compare the digests::

    PYTHONPATH=/path/to/reference python scripts/env_sha.py --steps 250
    PYTHONPATH=/path/to/candidate python scripts/env_sha.py --steps 250

``--env-kwargs`` passes constructor arguments as JSON (e.g. ``'{"control_dt": null}'``); ``--sim-mode harness``
or ``standing`` runs the env with ``SimConfig.harness()``'s or ``SimConfig.standing()``'s foot lock, stance,
balance and floor time constant fields (as ``scripts/bench_env.py --sim-mode`` does; ``preset``: the env's own).
Compare digests made on one machine only: floating point differs between CPUs, so the same tree gives other
digests elsewhere (the ones quoted in docs/ up to session 31 came from one machine; an AMD EPYC machine gives
639b1165…, 45a73587…, 5a52bb87… for the harness at 715b032 with mujoco 3.17.0 and numpy 2.4.6).
The library never imports this script.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

import argparse  # noqa: E402
import hashlib  # noqa: E402
import json  # noqa: E402

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import socialaff_sim  # noqa: E402,F401  (registers the ids)
from socialaff_sim.environment.observation import OBSERVATION_KEYS  # noqa: E402

from bench_env import sim_options  # noqa: E402  (scripts/, sys.path[0])

ENV_ID = "socialaff_sim/SocialAffordance-v0"


def stream_digest(mode: str, steps: int, seed: int, kwargs: dict[str, object]) -> tuple[str, int]:
    """(SHA-256 hex digest, episodes started) of ``steps`` steps of policy ``mode`` (see the module docstring)."""
    env = gym.make(ENV_ID, action_mode="residual" if mode == "zero" else mode, **kwargs)
    zero = np.zeros(env.action_space.shape, env.action_space.dtype)
    env.action_space.seed(seed)
    rng = np.random.default_rng(seed)
    h = hashlib.sha256()
    episodes, live = 0, False
    for _ in range(steps):
        if not live:
            obs, _ = env.reset(seed=int(rng.integers(1 << 31)))
            episodes, live = episodes + 1, True
            for k in OBSERVATION_KEYS:
                h.update(np.ascontiguousarray(obs[k], np.float32).tobytes())
        obs, reward, term, trunc, info = env.step(zero if mode == "zero" else env.action_space.sample())
        for k in OBSERVATION_KEYS:
            h.update(np.ascontiguousarray(obs[k], np.float32).tobytes())
        terms = sorted(k for k in info if k.startswith("reward_"))
        h.update(np.array([reward, *(info[k] for k in terms)], np.float64).tobytes())
        h.update(repr((bool(term), bool(trunc), info["termination_reason"], terms)).encode())
        live = not (term or trunc)
    env.close()
    return h.hexdigest(), episodes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=250, help="steps per action mode")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--modes", nargs="+", default=["targets", "residual", "zero"], choices=["targets", "residual", "zero"])
    ap.add_argument("--env-kwargs", default="{}", help="constructor arguments, JSON")
    ap.add_argument("--sim-mode", default="preset", choices=["preset", "harness", "standing"],
                    help="the env's physics mode: the preset's own, or SimConfig.harness()'s / .standing()'s foot "
                         "lock, stance, balance and floor time constant fields")
    args = ap.parse_args()
    kwargs = json.loads(args.env_kwargs)
    env_kwargs = dict(kwargs)
    if args.sim_mode != "preset":
        env_kwargs["sim_config"] = sim_options(str(kwargs.get("physics", "fast")), None, None, None, args.sim_mode)
    out = {}
    for mode in args.modes:
        digest, episodes = stream_digest(mode, args.steps, args.seed, env_kwargs)
        out[mode] = {"sha256": digest, "episodes": episodes, "steps": args.steps}
    print(json.dumps({"env_id": ENV_ID, "env_kwargs": kwargs, "sim_mode": args.sim_mode, "seed": args.seed, **out},
                     indent=2))


if __name__ == "__main__":
    main()
