"""The Gymnasium environment: a robot reacting to a replayed person, one control period per step.

An episode replays one human instance (agent 0 of an interaction, chosen by the
reset seed from the environment's instances) in MuJoCo physics, with the robot
facing them; the robot is driven by the action through mink IK and its position
servos (:class:`~socialaff_sim.sim.simulator.Simulator`), and each step advances
the physics by one control period (``control_dt``, 0.015 s by default; a data frame
of the recording is split into control steps, :mod:`~socialaff_sim.environment.control`),
or by one whole frame with ``control_dt=None``. Observations are documented in
:mod:`socialaff_sim.environment.observation`, rewards in
:mod:`socialaff_sim.environment.reward`, actions below and in docs/environment.md.

Actions, a (5, 3) float32 :class:`~gymnasium.spaces.Box` (rows: base, left wrist,
right wrist, left ankle, right ankle; metres, robot frame), clipped to the space
(:mod:`~socialaff_sim.environment.actions`):

* ``targets``: the key-frame targets themselves, in ``EnvConfig.target_low … target_high``;
* ``residual``: offsets in [−ρ, ρ] added to the adapter's proposal for the frame
  (the ``proposal`` entry of the observation), so a policy learns corrections; ``residual_groups``
  (one offset per group of key joints, a (G, 3) box) and ``residual_tau`` (the offset low-pass
  filtered) make it fewer and slower numbers (:mod:`~socialaff_sim.environment.residual`).

Either way they are the targets for the end of the current data frame: held through the frame's control
steps they give the frame's physics exactly; changed within it, the IK is solved again.

The resulting targets are then projected onto what the robot's body can follow
(:mod:`~socialaff_sim.environment.action_limits`; ``info["action_adjustment"]`` says how far
each row was moved). Why an episode ended is ``info["termination_reason"]``
(:mod:`~socialaff_sim.environment.episode_end`), MuJoCo's warnings of the step ``info["physics_warnings"]``;
every ``info`` key is listed in :mod:`~socialaff_sim.environment.info`.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from ..errors import ConfigError, SimulationError, choices
from ..retarget.robot import RobotSpec, load_robot
from ..sim.simulator import SimConfig, Simulator, StepResult
from .action_limits import BodyEnvelope, EnvelopeConfig, FeasibleTargets
from .actions import ActionDecoder
from .adapters import AdapterFrame, AffordanceAdapter, AffordanceScore, GroundTruthAdapter, RobotPose
from .bodymap import RobotToAgent
from .config import CONTROL_DT, EnvConfig, physics_config
from .control import ControlClock
from .episode_end import EpisodeEnd, WarningMonitor
from .info import step_info
from .instances import DataSpec, EpisodePool, load_pool
from .model_adapter import ModelAdapter, ModelSpec, load_models
from .observation import ObservationLayout
from .rendering import FrameRenderer, HumanViewer, display_available
from .reward import RewardConfig, RewardTracker
from .tracks import EpisodeTracks

__all__ = ["SocialAffordanceEnv"]

_log = logging.getLogger(__name__)

RESET_OPTIONS = ("interaction", "instance")
_UNSCORED = AffordanceScore(0.0, 0.0, 0)  # the affordance term of a control step that does not end a frame


class SocialAffordanceEnv(gym.Env):
    """Play agent 1 of a two-person interaction with a humanoid robot, facing a replayed person.

    Parameters
    ----------
    interactions:
        Label(s) to play (e.g. ``"shake_hands"``); ``None``: every label of the data.
    data:
        Dataset spec (``"synthetic"``, ``"synthetic:SEED"``, ``"sbu:PATH"``, ...), a Dataset or a list of instances.
    robot:
        ``"ours"``, ``"cmu"`` or a robot mapping file (docs/robots.md).
    action_mode:
        ``"targets"`` or ``"residual"`` (see the module docstring).
    model:
        A fitted affordance model (file, object, or one per label): its synthesis gives the proposal and the
        sub-event belief, its spatial potentials the affordance reward. ``None``: the ground-truth adapter.
    adapter:
        A custom :class:`~socialaff_sim.environment.adapters.AffordanceAdapter` (instead of ``model``).
    history, max_frames, physics, control_dt, resolve_iterations, terminate_on_failure, fall_height, fall_tilt, render_width, render_height, residual_groups, residual_tau:
        Fields of :class:`~socialaff_sim.environment.config.EnvConfig` (``control_dt``: the simulated seconds
        of one env step, :mod:`~socialaff_sim.environment.control`; ``None``: one data frame).
    sim_config:
        Simulator settings (:class:`~socialaff_sim.sim.simulator.SimConfig`) used instead of the ``physics``
        preset's, e.g. ``dataclasses.replace(physics_config("fast"), compliant_person=False)`` (the
        trade-offs are measured in docs/environment.md, "Speed"); ``None``: the preset's.
    envelope:
        The envelope targets are projected into (:class:`~socialaff_sim.environment.action_limits.EnvelopeConfig`).
    reward:
        Term weights (:class:`~socialaff_sim.environment.reward.RewardConfig`).
    proxy_sigma:
        σ (m) of the ground-truth adapter's Gaussian proxy score (used when ``model`` is ``None``).
    render_mode:
        ``None``, ``"rgb_array"`` or ``"human"`` (needs a display).
    """

    metadata: dict[str, Any] = {"render_modes": ["rgb_array", "human"], "render_fps": 12}

    def __init__(
        self,
        interactions: str | Sequence[str] | None = None,
        data: DataSpec = "synthetic",
        robot: str | Path | RobotSpec = "ours",
        action_mode: str = "targets",
        model: ModelSpec | None = None,
        adapter: AffordanceAdapter | None = None,
        history: int = 4,
        max_frames: int | None = None,
        physics: str = "fast",
        control_dt: float | None = CONTROL_DT,
        resolve_iterations: int = 1,
        sim_config: SimConfig | None = None,
        reward: RewardConfig | None = None,
        terminate_on_failure: bool = True,
        fall_height: float = 0.5,
        fall_tilt: float = 60.0,
        envelope: EnvelopeConfig | None = None,
        proxy_sigma: float = 0.1,
        render_mode: str | None = None,
        render_width: int = 640,
        render_height: int = 480,
        residual_groups: Sequence[Sequence[str]] | None = None,
        residual_tau: float | None = None,
    ) -> None:
        self._init_kwargs = {k: v for k, v in locals().items() if k not in ("self", "__class__")}
        self.config = EnvConfig(
            action_mode=action_mode, history=history, max_frames=max_frames, physics=physics, control_dt=control_dt,
            resolve_iterations=resolve_iterations,
            terminate_on_failure=terminate_on_failure, fall_height=fall_height, fall_tilt=fall_tilt,
            render_width=render_width, render_height=render_height, residual_tau=residual_tau,
            residual_groups=None if residual_groups is None else tuple(
                (g,) if isinstance(g, str) else tuple(g) for g in residual_groups),
        )
        self.envelope = envelope or EnvelopeConfig()
        self.warnings = WarningMonitor()
        """MuJoCo's warnings on the physics, per step (``info["physics_warnings"]``) and in total (``warnings.totals``)."""
        if render_mode not in (None, *type(self).metadata["render_modes"]):
            raise ConfigError(f"render_mode: expected None, {choices(type(self).metadata['render_modes'])}, found {render_mode!r}")
        self.render_mode = render_mode
        self._viewer = HumanViewer() if render_mode == "human" else None
        self._frames = FrameRenderer(render_width, render_height) if render_mode == "rgb_array" else None
        self.pool: EpisodePool = load_pool(data, interactions, max_frames)
        if model is not None and adapter is not None:
            raise ConfigError("give either model= (a fitted affordance model) or adapter= (a custom adapter), not both")
        if adapter is None:
            adapter = ModelAdapter(load_models(model, self.pool.labels)) if model is not None else GroundTruthAdapter(proxy_sigma)
        elif not isinstance(adapter, AffordanceAdapter):
            raise ConfigError(f"adapter: expected an AffordanceAdapter (kind, subevent_names, reset, observe, "
                              f"log_likelihood), found {type(adapter).__name__}")
        self.adapter: AffordanceAdapter = adapter
        self.robot = robot if isinstance(robot, RobotSpec) else load_robot(robot)
        if sim_config is not None and not isinstance(sim_config, SimConfig):
            raise ConfigError(f"sim_config: expected None or a SimConfig, found {type(sim_config).__name__}")
        self._sim_config = physics_config(self.config.physics) if sim_config is None else sim_config
        self._sims: dict[str, Simulator] = {}
        self._to_agent = RobotToAgent()
        first = self.pool.instances[0]
        probe = self._simulator(first.label)
        probe.reset(first)
        n_joints = len(probe.joint_state()[0])
        m = probe.measurements
        self.feasible = FeasibleTargets(BodyEnvelope(
            arm=float(m.arm), leg=float(m.leg), shoulders=np.asarray(m.shoulders, float), hips=np.asarray(m.hips, float),
            base_height=float(probe.home_key_frames[0, 2]), ankle_height=float(np.mean(probe.home_key_frames[3:5, 2])),
        ), self.envelope)
        """The projection of targets onto what the robot's body can follow."""
        names = {lbl: self.adapter.subevent_names(lbl, self.pool.instances) for lbl in self.pool.labels}
        self.rewards = RewardTracker([self.pool.tasks[lbl] for lbl in self.pool.labels], reward)
        self.layout = ObservationLayout(
            history=self.config.history, n_joints=n_joints, n_subevents=max(1, *(len(n) for n in names.values())),
            interactions=self.pool.labels, subgoals=self.rewards.subgoal_names,
            position_bound=self.config.position_bound, velocity_bound=self.config.velocity_bound,
            residual_bound=None if self.config.residual_tau is None else self.config.residual_bound,
        )
        self.observation_space = self.layout.space()
        self._decoder = ActionDecoder(self.config, self.feasible)
        self.action_space = self._decoder.space
        self._end = EpisodeEnd(self.config.fall_height, self.config.fall_tilt, self.config.terminate_on_failure)
        modes = ["rgb_array"] + (["human"] if display_available() else [])
        self.metadata = {"render_modes": modes, "render_fps": float(first.fps)}
        self._index: int | None = None
        self._actions: list[np.ndarray] = []
        self.clock = ControlClock(self.config.control_dt)
        """How a data frame's physics steps are split into env steps."""
        self._tracks = EpisodeTracks(self.config.history)

    def warm_up(self) -> None:
        """Reset onto every instance once: compile each task's scene and cache each instance's reset, so that
        later resets replay cached arrays (what a first reset of each costs otherwise). Ends the episode in
        progress, if any (call :meth:`reset` next); leaves the env's random state alone."""
        for index in range(len(self.pool.instances)):
            self._start(index, 0)
        self._index = None

    # -- episode state -------------------------------------------------------------------
    def _simulator(self, label: str) -> Simulator:
        if label not in self._sims:
            self._sims[label] = Simulator(self.robot, self.pool.tasks[label], self._sim_config)
        return self._sims[label]

    @property
    def simulator(self) -> Simulator:
        """The simulator of the current episode."""
        self._require()
        return self._sim

    def _require(self) -> None:
        if self._index is None:
            raise SimulationError("SocialAffordanceEnv: call reset() before step() or render()")

    def _retarget(self, frame: AdapterFrame, t: int) -> None:
        """Set the proposal for frame ``t``: the adapter's, retargeted (``_reference``, NaN rows where it has
        none) and with those rows holding the robot's key frames (``_proposal``, the observation's)."""
        sim = self._sim
        self._reference = sim.retarget(frame.proposal, frame=t, subevent=frame.subevent_name, **frame.intent.kwargs())
        out = self._reference.copy()
        bad = ~np.isfinite(out).all(axis=1)
        if bad.any():
            out[bad] = sim.robot_key_frames()[bad]
        self._proposal = out

    def _start(self, index: int, adapter_seed: int) -> None:
        inter = self.pool.instances[index]
        self._index, self._adapter_seed = index, adapter_seed
        self._actions = []
        self._sim = sim = self._simulator(inter.label)
        self.adapter.reset(inter, rng=np.random.default_rng(adapter_seed))
        self._to_agent.reset()
        first = self.adapter.observe(0)
        # The model's synthesis sees agent 1's first T0 frames only, and so does the robot's placement.
        sim.reset(inter, placement_frames=getattr(self.adapter, "placement_frames", None))
        sim.settle(sim.retarget(first.proposal, frame=0, subevent=first.subevent_name, **first.intent.kwargs()))
        self.clock.reset(inter.fps, sim.n_sub)
        self._frame_obs: tuple[int, dict[str, np.ndarray]] | None = None
        self._decoder.reset()
        self._tracks.reset(sim, inter)
        self.rewards.reset(sim.task)
        self._frame = self.adapter.observe(min(1, inter.n_frames - 1))
        self._retarget(self._frame, 1)
        self._scored_frame = first
        self._robot_keys = sim.robot_key_frames()
        self._last: StepResult | None = None
        self._last_terms: dict[str, float] = {}
        self._done = False
        self._reason: str | None = None
        self._step_warnings = dict.fromkeys(self.warnings.totals, 0)
        self.warnings.reset(sim.data)
        self._end.reset(sim)
        self.metadata["render_fps"] = float(inter.fps) * self.clock.per_frame

    def _advance(self, action: np.ndarray) -> tuple[float, dict[str, float], StepResult]:
        sim, cfg = self._sim, self.config
        a = self._decoder.clip(action)
        self._actions.append(a.copy())
        k = sim.substep
        end = self.clock.end_of(k)
        targets = self._decoder.targets(a, self._proposal, bool(k), sim.last_targets[0], sim.interaction.fps,  # type: ignore[union-attr]
                                        (end - k) * self.clock.step_seconds)
        if self.clock.needs_solve(k, targets):
            sim.solve(targets, subevent=self._frame.subevent_name, iterations=cfg.resolve_iterations if k else None)
        res = sim.advance(end - k)
        self._step_warnings = self.warnings.step(sim.data)
        if res is None:  # a control step within the frame: the physics' terms; the affordance is scored per frame
            self._robot_keys = sim.robot_key_frames()
            terms = self.rewards.step(_UNSCORED, sim.scorer)
            self._last_terms = terms
            self._reason = self._end.reason(sim, self._step_warnings, self._robot_keys)
            self._done = self._reason is not None
            return RewardTracker.total(terms), terms, self._last  # type: ignore[return-value]
        t = sim.frame
        obj_r = sim.object_position()
        obj_data = None if obj_r is None else sim.frame_R.to_world(obj_r) - sim.offset
        self._robot_keys = robot_keys = sim.robot_key_frames()
        pose = RobotPose(t, robot_keys, self._reference, obj_data, lambda: self._to_agent(sim, robot_keys, t))
        score = self.adapter.log_likelihood(self._frame.subevent, pose)
        terms = self.rewards.step(score, sim.scorer)
        self._scored_frame = self._frame
        if obj_r is not None:
            self._tracks.push_object(obj_r)
        if not sim.done:
            self._frame = self.adapter.observe(t + 1)
            self._retarget(self._frame, t + 1)
        self._last, self._last_terms = res, terms
        self._reason = self._end.reason(sim, self._step_warnings, self._robot_keys)
        self._done = self._reason is not None
        return RewardTracker.total(terms), terms, res

    # -- observation and info ----------------------------------------------------------------
    def _observation(self) -> dict[str, np.ndarray]:
        sim = self._sim
        q, qd = sim.joint_state()
        if self._frame_obs is None or self._frame_obs[0] != sim.frame:  # the frame's entries, shared by its steps
            self._frame_obs = (sim.frame, self.layout.frame_entries(
                human_track=self._tracks.human, human_mask=self._tracks.mask, object_history=self._tracks.object,
                object_present=sim.carry is not None, proposal=self._proposal, belief=self._frame.belief,
                interaction=self.pool.instances[self._index].label, frame=sim.frame))  # type: ignore[index]
        return self.layout.assemble(self._frame_obs[1], self.layout.step_entries(
            robot_keys=self._robot_keys, joint_pos=q, joint_vel=qd,
            subgoal_progress=self.rewards.progress(sim.scorer),
            subgoal_achieved={r.name: bool(r.success) for r in sim.scorer.subgoals},
            subgoal_current={r.name: bool(r.current) for r in sim.scorer.subgoals},
            frame=sim.frame, n_frames=sim.n_frames, phase=sim.substep / sim.n_sub,
            residual_offset=self._decoder.offsets.offset,
        ))

    def _info(self, terms: dict[str, float] | None) -> dict[str, Any]:
        inter = self.pool.instances[self._index]  # type: ignore[index]
        return step_info(self._sim, inter, self._scored_frame, self.adapter.kind, self._reason, self._step_warnings,
                         self._decoder.adjustment, terms)

    # -- Gymnasium API -----------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
        """Start an episode on an instance drawn with the env's RNG (``options``: ``interaction`` or ``instance`` id)."""
        super().reset(seed=seed)
        options = dict(options or {})
        unknown = sorted(set(options) - set(RESET_OPTIONS))
        if unknown:
            raise ConfigError(f"reset options: unknown keys {choices(unknown)}; valid keys: {choices(RESET_OPTIONS)}")
        candidates = self.pool.indices(interaction=options.get("interaction"), instance=options.get("instance"))
        index = candidates[int(self.np_random.integers(len(candidates)))]
        self._start(index, int(self.np_random.integers(2**63)))
        if self.render_mode == "human":
            self.render()
        return self._observation(), self._info(None)

    def step(self, action: np.ndarray) -> tuple[dict[str, np.ndarray], float, bool, bool, dict[str, Any]]:
        """Advance one control period (or one frame with ``control_dt=None``); see the module docstring."""
        self._require()
        if self._done:
            raise SimulationError(f"SocialAffordanceEnv: the episode has ended ({self._reason}); call reset()")
        reward, terms, _ = self._advance(action)
        if self.render_mode == "human":
            self.render()
        truncated = self._reason == "physics_unstable"
        if truncated:
            _log.warning("%s: MuJoCo reported an unstable simulation at frame %d (%s); the episode is truncated",
                         self.pool.instances[self._index].instance_id, self._sim.frame,  # type: ignore[index]
                         ", ".join(f"{k} {v}" for k, v in self._step_warnings.items() if v))
        return self._observation(), reward, self._done and not truncated, truncated, self._info(terms)

    def render(self) -> np.ndarray | None:
        """``rgb_array``: (H, W, 3) uint8 frame with a caption; ``human``: refresh the window; else ``None``."""
        if self.render_mode is None:
            return None
        self._require()
        sim = self._sim
        if self._viewer is not None:
            self._viewer.show(sim)
            return None
        assert self._frames is not None
        inter = self.pool.instances[self._index]  # type: ignore[index]
        name = self._scored_frame.subevent_name
        total = RewardTracker.total(self._last_terms) if self._last_terms else 0.0
        caption = [f"{inter.label}  {inter.instance_id}  frame {sim.frame}/{sim.n_frames - 1}",
                   f"sub-event: {name or '?'}   reward {total:+.2f}"]
        return self._frames.render(sim, caption)

    def close(self) -> None:
        """Free the renderers (idempotent)."""
        if self._frames is not None:
            self._frames.close()
        if self._viewer is not None:
            self._viewer.close()

    # -- pickling ----------------------------------------------------------------------------
    def __getstate__(self) -> dict[str, Any]:
        rng = self._np_random
        return {
            "kwargs": self._init_kwargs,
            "rng": None if rng is None else rng.bit_generator.state,
            "seed": self._np_random_seed,
            "spec": self.spec,
            "episode": None if self._index is None else (self._index, self._adapter_seed, [a.copy() for a in self._actions]),
        }

    def __setstate__(self, state: Mapping[str, Any]) -> None:
        """Rebuild from the constructor arguments, then replay the current episode's actions (deterministic)."""
        self.__init__(**state["kwargs"])  # type: ignore[misc]
        self.spec = state["spec"]
        if state["rng"] is not None:
            gen = np.random.Generator(getattr(np.random, state["rng"]["bit_generator"])())
            gen.bit_generator.state = state["rng"]
            self._np_random, self._np_random_seed = gen, state["seed"]
        if state["episode"] is not None:
            index, adapter_seed, actions = state["episode"]
            self._start(index, adapter_seed)
            for a in actions:
                self._advance(a)
