"""Train a residual policy on top of the affordance model with Stable-Baselines3, and test it on held-out instances.

The environment's ``residual`` action mode adds the policy's offsets (at most ±0.3 m per
coordinate; the policy's action [−1, 1] is scaled to ±``--action-scale``, 0.1 m by default)
to the key-frame targets the affordance model proposes (its causal online synthesis of
agent 1). The environment steps at its default control rate (one env step per 0.015 s
control period, ``--control-dt``; ``none`` gives the older one step per data frame), so
the policy may change its residual every control step. This script:

1. generates the synthetic training data (``--seed``; ``--train-instances`` per
   interaction) — or, with ``--data SPEC ...`` (``handover:PATH``, ``sbu:PATH``,
   ``nuisi:PATH``, ...), splits each recorded (dataset, label) class into ``--folds``
   folds under ``--split`` (pair-disjoint by default, NuiSI by contiguous block)
   and trains on all folds but ``--held-out-fold`` — and fits one affordance model
   per label on the training instances (or loads them with ``--models DIR``);
2. trains one PPO policy (Stable-Baselines3, observations flattened and
   normalized with ``VecNormalize``, actions in [−1, 1]) on episodes
   of those training instances, both interactions in one environment (the
   observation carries the interaction's one-hot);
3. evaluates, on HELD-OUT instances — a second synthetic dataset generated with
   seed ``--seed + 1`` (other actors' bodies, other instances; none of them seen
   by the model fit or by the policy), or the held-out fold of the recordings —
   the trained residual (deterministic
   actions) against the affordance model alone (zero residual), one episode per
   held-out instance, the same reset seed for both policies, so every pair of
   episodes shares the instance and the synthesizer's sampling: the comparison
   is paired;
4. writes ``results.json`` (per-episode rows, rates with Wilson 95 % intervals,
   mean returns and the paired differences with stratified bootstrap 95 %
   intervals), the learning curve ``learning_curve.png`` (+ ``curve.json``),
   the policy ``residual_ppo.zip`` and its observation statistics
   ``vecnormalize.pkl``.

``--select-every E`` chooses the final policy on the TRAINING side (``scripts/_residual_select.py``): checkpoints
after every E-th update, played deterministically on the training instances of the acting labels, against the
start; the held-out arms are played after the choice.

``--reference-only`` stops after step 1 and plays the zero residual on the TRAINING
instances alone (``reference.json``): how much room a residual has, measured without
touching the held-out instances.

"Success" is the environment's ``info["success"]``: every sub-goal of the task
met and no failure condition triggered. The target (issue 26): the trained
residual's success minus the affordance model's, paired over the held-out
episodes, has a 95 % interval above zero. Needs the ``[rl]`` extra. Example::

    OMP_NUM_THREADS=1 nice -n 10 python scripts/train_residual.py --timesteps 300000 --out rl_out
    # on the shared recordings (labels of one task, e.g. shaking_hands and handshake, are one stratum):
    OMP_NUM_THREADS=1 nice -n 10 python scripts/train_residual.py --out rl_real \
        --data handover:../shared/data/handover_h2h sbu:../shared/data/sbu_kinect_interaction nuisi:../shared/data/nuisi_v1 \
        --interactions hand_over shaking_hands handshake
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # no rendering, but dm_control picks a GL backend on import

import dataclasses  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
import sys  # noqa: E402
from collections.abc import Callable, Mapping, Sequence  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.callbacks import CallbackList  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor, VecNormalize  # noqa: E402

from socialaff_sim._atomic import atomic_write_text  # noqa: E402
from socialaff_sim.data.interaction import Interaction  # noqa: E402
from socialaff_sim.environment import SocialAffordanceEnv  # noqa: E402
from socialaff_sim.environment.config import CONTROL_DT, EnvConfig  # noqa: E402
from socialaff_sim.environment.reward import RewardConfig  # noqa: E402
from socialaff_sim.errors import ConfigError, SocialAffError  # noqa: E402
from socialaff_sim.learning import SocialAffordanceModel  # noqa: E402
from socialaff_sim.learning.config import LearningConfig  # noqa: E402

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:  # run as `python scripts/train_residual.py` it is sys.path[0]; the tests load this file by path
    sys.path.append(_HERE)
from _residual_cli import parser, settings_from_args  # noqa: E402
from _residual_curve import CurveRecorder, plot_curve  # noqa: E402
from _residual_episodes import held_out_episodes, run_episodes, trained_policy, training_episodes, zero_policy  # noqa: E402
from _residual_eval import evaluate_held_out  # noqa: E402
from _residual_data import DEFAULT_SPLITS, build_data, describe_split, fit_models, parse_splits  # noqa: E402
from _residual_reward import FallPenalty  # noqa: E402
from _residual_gate import GatedResidual, check_gate  # noqa: E402
from _residual_reach import ReachResidual  # noqa: E402
from _residual_select import CheckpointSelector  # noqa: E402
from _residual_report import load_reference, load_start_reference, reference_lines, reference_summary, result_lines  # noqa: E402

LABELS = ("shake_hands", "hand_over")
RESIDUAL_BOUND = EnvConfig().residual_bound


@dataclasses.dataclass(frozen=True)
class Settings:
    """One run of the example; every field is a command-line flag."""

    labels: tuple[str, ...] = LABELS
    """Interactions trained and evaluated (one policy for all of them)."""
    seed: int = 0
    """Seed of the training data, the model fits, the policy and the evaluation's reset seeds (held-out data: seed + 1)."""
    policy_seed: int | None = None
    """Seed of PPO and of the training environments' resets only (the split, the models, the selection and held-out
    episodes and the bootstrap keep ``seed``): a replicate of a run's training; ``None``: ``seed``."""
    train_instances: int = 48
    """Synthetic training instances per interaction (the model fit and the RL episodes use these)."""
    eval_instances: int = 50
    """Held-out instances per interaction; one evaluation episode each, per policy."""
    fit_iterations: int = LearningConfig().iterations
    """Algorithm 1 iterations of each model fit."""
    timesteps: int = 300_000
    """PPO environment steps (over all sub-environments)."""
    n_envs: int = 8
    """Sub-environments stepped in one process (``DummyVecEnv``)."""
    n_steps: int = 256
    """PPO rollout length per sub-environment between updates."""
    batch_size: int = 256
    """PPO minibatch size."""
    n_epochs: int = 5
    """PPO epochs per update."""
    learning_rate: float = 1e-4
    """Adam step size."""
    target_kl: float | None = None
    """PPO's KL target: an update's epochs stop once the approximate KL divergence from the rollout's policy
    exceeds 1.5 times this; ``None``: every epoch runs."""
    gamma: float = 0.998
    """Discount factor per env step (0.998 per 0.015 s control step ≈ 0.99 per frame of a 12 fps instance)."""
    gae_lambda: float = 0.98
    """λ of PPO's generalized advantage estimate."""
    log_std_init: float = -2.3
    """Initial log standard deviation of the Gaussian policy in the rescaled action space [−1, 1]: e^−2.3 ≈ 0.1,
    i.e. about 1 cm of exploration noise on the ±0.1 m residual (``action_scale``), so early episodes stay close
    to the proposal."""
    use_sde: bool = False
    """Generalized state-dependent exploration (SB3's gSDE): the exploration noise is a function of the state
    drawn anew every ``sde_sample_freq`` steps, so it is held over a stretch of an episode instead of white;
    ``log_std_init`` is then the log σ of the noise weights (``--use-sde``)."""
    sde_sample_freq: int = -1
    """With ``use_sde``: steps between noise draws (−1: once per rollout)."""
    eval_constant: tuple[float, ...] = ()
    """A constant action (policy units) also played on the held-out episodes and compared with the zero residual
    (``results["summary_constant"]``; what the action's parametrization gives without learning); empty: none."""
    hidden: int = 256
    """Width of the two hidden layers of the policy and value networks."""
    action_scale: float = 0.1
    """ρ_π [m]: the policy's action [−1, 1] is a residual of ±ρ_π per coordinate (at most the environment's
    ``residual_bound``, 0.3 m)."""
    residual_groups: tuple[str, ...] = ()
    """The environment's ``residual_groups`` as flags: one word per group, its key joints joined by ``+``
    (``base left_wrist+right_wrist``: the action is one offset for the base and one shared by both wrists);
    empty: one offset per key joint (the (5, 3) action)."""
    residual_tau: float | None = None
    """τ_r [s]: the environment's ``residual_tau`` (the offset follows the action through a low-pass filter of
    this time constant); ``None``: no filter."""
    reach_scale: float | None = None
    """ρ_reach [m]: with a value, the task-frame residual of ``_residual_reach.ReachResidual``: the action is the
    base's offset (3 numbers, ±``action_scale`` m each) and one reach per hand (±ρ_reach m along the line from
    the proposal's wrist to the hand's target, the object or the person's nearer wrist); ``None``: the plain
    residual (``residual_groups``). Not with ``residual_groups``."""
    train_fall_penalty: float = 0.0
    """w_fell [reward]: subtracted once when a TRAINING episode ends because the robot fell
    (``_residual_reward.FallPenalty``; the environment's reward has no such term); 0: the environment's reward."""
    train_affordance_weight: float = RewardConfig().affordance_weight
    """w_a of the TRAINING environments' reward (also the learning curve's and its zero-residual reference's);
    the held-out evaluation keeps the environment's default reward, so its returns stay comparable across runs."""
    physics: str = "fast"
    """The environment's physics preset."""
    control_dt: float | None = CONTROL_DT
    """The environment's control period, s (its default, 0.015 s: one env step per control period);
    ``None``: one env step per data frame, as the first two recorded runs were trained and evaluated."""
    max_frames: int | None = None
    """Cut every instance to its first frames (short episodes; tests only)."""
    robot: str = "ours"
    """The environment's robot."""
    data: tuple[str, ...] = ()
    """Recorded dataset specs (``handover:PATH``, ``sbu:PATH``, ``nuisi:PATH``, ...); empty: the synthetic
    datasets (seeds ``seed`` and ``seed + 1``). Each (dataset, label) class is split on its own
    (``scripts/_residual_data.py``); ``train_instances`` / ``eval_instances`` are then unused."""
    split: tuple[str, ...] = DEFAULT_SPLITS
    """Split of the recorded data: a name for every dataset kind, ``KIND=NAME`` for one kind
    (:data:`socialaff_sim.evaluation.splits.SPLITS`)."""
    folds: int = 2
    """Folds each recorded class is dealt into; one is held out, the others are trained on."""
    held_out_fold: int = 0
    """The fold held out."""
    residual_labels: tuple[str, ...] = ()
    """The interactions the residual acts on (``_residual_gate.GatedResidual``): elsewhere the policy's action is
    replaced by zeros (the affordance model alone), and training episodes are drawn from these labels only;
    empty: every label of ``labels``."""
    action_bias: tuple[float, ...] = ()
    """b (policy units): on the acting labels the environment gets clip(b + a, −1, 1) for the policy's action a, so
    the untrained policy plays the constant b and learns a correction to it; empty: no bias. With either of these
    two the held-out evaluation also plays the zero action through the gate (the start: b on the acting labels,
    nothing elsewhere; ``results["summary_start"]``, and the trained policy against it, ``summary_learned``)."""

    select_every: int = 0
    """E (PPO updates): with E > 0, the policy is played deterministically on the selection episodes (every
    training instance of the acting labels, the ``--reference-only`` reset seeds) after every E-th update and after
    the last one, and the result is the checkpoint with the most successes if it beats the start there, else the
    start (``_residual_select``; the held-out "residual" arm then plays the start); 0: the last policy."""
    held_out_seed_base: int = 10_000
    """Reset seed of the first held-out episode (the k-th: this + 1000·seed + k); a new base gives fresh episodes
    of the same held-out instances."""

    @property
    def gated(self) -> bool:
        """Whether the residual goes through :class:`GatedResidual` (a label set or a bias is given)."""
        return bool(self.residual_labels or self.action_bias)


# -- data and environments -----------------------------------------------------------------------------------------
def make_env(s: Settings, instances: Sequence[Interaction], models: Mapping[str, SocialAffordanceModel],
             training: bool = False, gate: bool = False) -> gym.Env:
    """The residual-mode environment as SB3 wants it: flat float32 observation, a flat action in [−1, 1] that is
    a residual of ±``s.action_scale`` m per coordinate. ``training``: with the training reward
    (``s.train_affordance_weight``, and ``s.train_fall_penalty`` when it is not 0); otherwise the environment's default
    reward. ``gate`` (with ``s.gated``): through :class:`GatedResidual` (``s.residual_labels``, ``s.action_bias``;
    training environments draw their episodes from the acting labels only)."""
    env = _residual_env(s, instances, models, training)
    if gate and s.gated:
        env = GatedResidual(env, s.residual_labels or s.labels, s.action_bias, train_only=training)
    return env


def _residual_env(s: Settings, instances: Sequence[Interaction], models: Mapping[str, SocialAffordanceModel],
                  training: bool) -> gym.Env:
    if not 0.0 < s.action_scale <= RESIDUAL_BOUND:
        raise ConfigError(f"--action-scale: expected a residual in (0, {RESIDUAL_BOUND}] m, found {s.action_scale!r}")
    reward = dataclasses.replace(RewardConfig(), affordance_weight=s.train_affordance_weight) if training else None
    groups = [g.split("+") for g in s.residual_groups] or None
    if s.reach_scale is not None and groups is not None:
        raise ConfigError("--reach-scale: not with --residual-groups (the reach residual sets every row itself)")
    env: gym.Env = SocialAffordanceEnv(interactions=list(s.labels), data=list(instances), action_mode="residual",
                                       model=dict(models), physics=s.physics, robot=s.robot, max_frames=s.max_frames,
                                       control_dt=s.control_dt, reward=reward, residual_groups=groups,
                                       residual_tau=s.residual_tau)
    if training and s.train_fall_penalty != 0.0:
        env = FallPenalty(env, s.train_fall_penalty)
    if s.reach_scale is not None:  # its action is already the policy's [−1, 1] box
        return gym.wrappers.FlattenObservation(ReachResidual(env, s.action_scale, s.reach_scale))
    env = gym.wrappers.FlattenObservation(env)
    shape = env.action_space.shape
    flat = gym.spaces.Box(-1.0, 1.0, shape=(int(np.prod(shape)),), dtype=np.float32)
    scale = np.float32(s.action_scale)
    return gym.wrappers.TransformAction(env, lambda a: (scale * np.asarray(a, np.float32)).reshape(shape), flat)


# -- training ------------------------------------------------------------------------------------------------------
def train(s: Settings, train_set: Sequence[Interaction], models: Mapping[str, SocialAffordanceModel],
          log: Callable[[str], None] | None = None, budget_s: float | None = None
          ) -> tuple[PPO, VecNormalize, CurveRecorder, CheckpointSelector | None]:
    """Train PPO on the training instances for ``s.timesteps`` steps, or until ``budget_s`` seconds of wall time
    (the start's and the checkpoints' selection episodes included) have passed (checked after each rollout);
    returns the agent, its observation normalizer, the recorder (curve rows, the steps trained on) and, with
    ``s.select_every``, the selector (the agent and normalizer then hold the chosen checkpoint, or the last
    policy if the start was kept: ``selector.chosen is None``)."""
    torch.set_num_threads(1)
    venv = DummyVecEnv([lambda: make_env(s, train_set, models, training=True, gate=True) for _ in range(s.n_envs)])
    policy_seed = s.seed if s.policy_seed is None else s.policy_seed
    venv.seed(policy_seed)
    norm = VecNormalize(VecMonitor(venv), norm_obs=True, norm_reward=True, gamma=s.gamma)
    agent = PPO(
        "MlpPolicy", norm, n_steps=s.n_steps, batch_size=s.batch_size, n_epochs=s.n_epochs,
        learning_rate=s.learning_rate, target_kl=s.target_kl, gamma=s.gamma, gae_lambda=s.gae_lambda, seed=policy_seed, device="cpu", verbose=0,
        use_sde=s.use_sde, sde_sample_freq=s.sde_sample_freq,
        policy_kwargs={"log_std_init": s.log_std_init, "net_arch": {"pi": [s.hidden] * 2, "vf": [s.hidden] * 2}},
    )
    recorder = CurveRecorder(log, budget_s=budget_s)
    selector = None
    if s.select_every > 0:
        env = make_env(s, train_set, models, training=True, gate=True)
        selector = CheckpointSelector(env, selection_episodes(s, train_set), norm, s.select_every,
                                      s.n_steps * s.n_envs, log)
        selector.play_start(zero_policy(env))
    agent.learn(total_timesteps=s.timesteps, callback=CallbackList([recorder] + ([selector] if selector else [])))
    norm.training = False
    if selector is not None:
        selector.finish(agent, recorder.updated_timesteps // (s.n_steps * s.n_envs))
    return agent, norm, recorder, selector


def selection_episodes(s: Settings, train_set: Sequence[Interaction]) -> list[tuple[str, int]]:
    """(instance, reset seed) of the selection: the ``--reference-only`` run's episodes of the acting labels."""
    acting = set(s.residual_labels or s.labels)
    label = {i.instance_id: i.label for i in train_set}
    return [(i, seed) for i, seed in training_episodes(list(label), s.seed) if label[i] in acting]


# -- the whole run -------------------------------------------------------------------------------------------------
def reference_rows(s: Settings, train_set: Sequence[Interaction], models: Mapping[str, SocialAffordanceModel],
                   gate: bool = False) -> tuple[list[dict[str, Any]], dict[str, dict[str, float]]]:
    """The zero residual once on every TRAINING instance, with the training reward: the episode rows and, per
    label, the success rate and mean return (the learning curve's dashed references). ``gate``: the zero action
    through the run's gate and bias instead (its start; the curve's dotted references)."""
    train_env = make_env(s, train_set, models, training=True, gate=gate)
    train_eps = training_episodes([i.instance_id for i in train_set], s.seed)
    ref_rows = run_episodes(train_env, train_eps, zero_policy(train_env))
    return ref_rows, reference_summary(ref_rows, s.labels)


def run(s: Settings, out: Path, models_dir: Path | None = None, log: Callable[[str], None] = lambda m: print(m, flush=True),
        budget_s: float | None = None, reference_only: bool = False, reference_file: Path | None = None) -> dict[str, Any]:
    """Fit (or load), train (at most ``budget_s`` s of wall time, if given), evaluate and write everything into
    ``out``; returns the results written. ``reference_only``: stop after the zero residual on the training
    instances (no training, nothing held out is played) and write ``reference.json``; ``reference_file``: take
    the learning curve's zero-residual reference from such a file instead of playing it again."""
    out.mkdir(parents=True, exist_ok=True)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    train_set, held_out = build_data(s)
    split = describe_split(s, train_set, held_out)
    if models_dir is not None:
        models = {lbl: SocialAffordanceModel.load(models_dir / f"{lbl}.npz") for lbl in s.labels}
    else:
        models = fit_models(s, train_set)
        (out / "models").mkdir(exist_ok=True)
        for lbl, m in models.items():
            m.save(out / "models" / f"{lbl}.npz")
    reference_saved = None if reference_file is None else load_reference(reference_file, s)
    log(f"models ready ({time.perf_counter() - wall0:.0f} s)")
    if reference_only:
        ref_rows, reference = reference_rows(s, train_set, models)
        ref = {"settings": dataclasses.asdict(s), "split": split, "train_reference_zero_residual": reference,
               "episodes": ref_rows}
        if s.gated:  # the start (the bias on the acting labels) on the same training episodes
            ref["episodes_start"], ref["train_reference_start"] = reference_rows(s, train_set, models, gate=True)
        ref |= {"total_wall_s": time.perf_counter() - wall0, "total_cpu_s": time.process_time() - cpu0}
        atomic_write_text(out / "reference.json", json.dumps(ref, indent=2))
        return ref
    held_env = make_env(s, held_out, models)
    held_gated = make_env(s, held_out, models, gate=True) if s.gated else None  # bad --residual-labels fail here
    if s.eval_constant and len(s.eval_constant) != int(np.prod(held_env.action_space.shape)):
        raise ConfigError(f"--eval-constant: expected {int(np.prod(held_env.action_space.shape))} numbers, "
                          f"found {len(s.eval_constant)}")
    log(f"training {s.timesteps} steps on {len(train_set)} instances")
    wall1 = time.perf_counter()
    agent, norm, recorder, selector = train(s, train_set, models, log, budget_s)
    train_wall = time.perf_counter() - wall1
    curve = [r for r in recorder.rows if r["timesteps"] <= recorder.updated_timesteps]
    agent.save(out / "residual_ppo.zip")
    norm.save(str(out / "vecnormalize.pkl"))
    log(f"trained in {train_wall:.0f} s wall ({len(curve)} training episodes); evaluating")

    # References for the curve: the zero residual (and the start) once on every training instance, training reward.
    reference = reference_saved if reference_saved is not None else reference_rows(s, train_set, models)[1]
    start = None if reference_file is None else load_start_reference(reference_file, s)
    if start is None and s.gated:
        start = reference_rows(s, train_set, models, gate=True)[1]
    selection = None if selector is None else {"start": selector.start, "checkpoints": selector.checkpoints,
                                               "chosen": selector.chosen, "episodes": len(selector.episodes)}
    plot_curve(curve, reference, out / "learning_curve.png", start=start, selection=selection)

    # Held-out evaluation: the same (instance, reset seed) pairs for every policy.
    episodes = held_out_episodes([i.instance_id for i in held_out], s.seed, s.held_out_seed_base)
    kept_start = selector is not None and selector.chosen is None  # the held-out "residual" arm is the start
    evaluated = evaluate_held_out(held_env, held_gated, episodes, None if kept_start else trained_policy(agent, norm),
                                  s.seed, s.eval_constant)
    results = {
        "settings": dataclasses.asdict(s),
        "held_out": split["held_out"], "split": split,
        "train_wall_s": train_wall, "total_wall_s": time.perf_counter() - wall0,
        "total_cpu_s": time.process_time() - cpu0, "training_episodes": len(curve),
        "timesteps_trained": recorder.updated_timesteps, "stopped_by_budget": recorder.stopped,
        "train_reference_zero_residual": reference, "train_reference_start": start, "selection": selection,
        **evaluated,
    }
    atomic_write_text(out / "curve.json", json.dumps(curve))
    atomic_write_text(out / "results.json", json.dumps(results, indent=2))
    return results


def main() -> None:
    ap = parser(Settings, __doc__)
    args = ap.parse_args()
    budget = None if args.budget_minutes is None else 60.0 * args.budget_minutes
    try:
        s = settings_from_args(Settings, args)
        parse_splits(s.split)  # a bad --split fails before anything runs, and so does a bad gate
        if s.gated:
            check_gate(s.labels, s.residual_labels or s.labels, s.action_bias,
                       5 if s.reach_scale is not None else 3 * (len(s.residual_groups) or 5))
        if s.select_every < 0:
            raise ConfigError(f"--select-every: expected a number of PPO updates >= 0 (0: off), found {s.select_every}")
        r = run(s, args.out, args.models, budget_s=budget, reference_only=args.reference_only, reference_file=args.reference)
    except SocialAffError as err:  # bad flags or data: one line naming the flag, exit 2 (results are written atomically)
        print(f"train_residual.py: error: {err}", file=sys.stderr)
        raise SystemExit(2) from None
    print("\n".join(reference_lines(r) if args.reference_only else result_lines(r)))


if __name__ == "__main__":
    main()
