"""One interaction through the whole loop: learn a model, synthesize the robot's reaction to a
held-out human, compare with the baselines, retarget and simulate it in MuJoCo, render it."""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..data.dataset import Dataset
from ..errors import RenderingUnavailableError
from ..evaluation.metrics import key_joint_error
from ..evaluation.registry import get_method
from ..inference import BodyFitter, SynthesisConfig, synthesize
from ..inference.plot import plot_key_joint_tracks
from ..inference.protocol import Prediction, observed_part
from ..learning.config import LearningConfig
from ..learning.estimator import SocialAffordanceModel
from ..model.figures import draw_groupings
from ..model.joints import instance_frame
from ..retarget.model_source import ModelSource
from ..retarget.robot import load_robot
from ..retarget.sources import GroundTruthSource
from ..sim.episode import run_episode
from ..sim.simulator import SimConfig, Simulator
from ..sim.tasks import task_for_label
from ..sim.video import EpisodeRecorder

__all__ = ["DemoConfig", "InteractionResult", "Progress", "held_out", "physics_modes", "run_interaction"]

Progress = Callable[[str], None]


@dataclass(frozen=True)
class DemoConfig:
    """Settings of the demo: the real algorithms with settings that finish quickly."""

    iterations: int = 0
    """[—]: Outer MCMC iterations of Algorithm 1 after its initial parse (the library's default 0; the paper
    uses 100)."""
    n_test: int = 3
    """[—]: Held-out instances per interaction (actors never seen in training) for the error table."""
    baselines: tuple[str, ...] = ("hmm", "promp")
    """[—]: Methods the full model is compared with on the held-out instances."""
    robot: str = "ours"
    """[—]: Robot simulated: a shipped robot (``"ours"``, ``"cmu"``, ``"unitree_h1"``, ``"unitree_g1"``) or a
    mapping file (docs/robots.md)."""
    mjcf: str | None = None
    """[—]: The robot's MJCF file, for robots whose model the project does not ship (the Unitree ones)."""
    video: bool = True
    """[—]: Render an MP4 and a contact sheet of the simulated reaction (needs EGL offscreen rendering)."""
    width: int = 640
    """[px]: Video width, pixels."""
    height: int = 480
    """[px]: Video height, pixels."""
    seed: int = 0
    """[—]: Seed of the data and every sampler."""
    contact_completion: bool = True
    """[—]: Whether the simulator completes the contacts the synthesized reaction is making
    (``SimConfig.contact_completion``, :mod:`~socialaff_sim.retarget.contact_completion`); off: the scaled
    key-joint targets go to the IK as they are."""
    physics: str | None = None
    """[—]: The physics mode simulated (:data:`~socialaff_sim.sim.sim_config.PHYSICS_MODES`): ``harness``
    (position servos, the robot's root hanging from a compliant harness) or ``standing`` (the balance controller
    stands the robot on its own feet while they are planted; docs/design.md §5); ``None``: the robot's own
    (:attr:`~socialaff_sim.retarget.robot.RobotSpec.physics`)."""

    def __post_init__(self) -> None:
        if self.physics is not None:
            SimConfig.mode(self.physics)  # an unknown mode: a ConfigError naming the choices


@dataclass
class InteractionResult:
    """What the demo produced for one interaction (paths are relative to the output folder)."""

    label: str
    instance: str
    subevents: list[tuple[str, float]]
    """Learned sub-events and their mean durations, seconds."""
    groupings_png: str
    synthesis_png: str
    errors: dict[str, float]
    """Average key-joint error (m) of each method over the held-out instances."""
    n_test: int
    simulation: dict[str, Any] = field(default_factory=dict)
    """Metrics of the simulated reaction (source = model) ."""
    reference: dict[str, Any] = field(default_factory=dict)
    """Metrics of the ground-truth replay through the same pipeline."""
    video: str | None = None
    contact_sheet: str | None = None
    video_note: str = ""
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def physics_mode(self) -> str:
        """The physics mode the synthesized reaction ran in, as its metrics name it (``"not recorded"`` if absent)."""
        return str((self.simulation.get("support") or {}).get("mode", "not recorded"))

    @property
    def contact_support(self) -> float | None:
        """The synthesized reaction's outside support over its contact phase (mean fraction of the robot's weight
        over the frames where a sub-goal's contact holds); ``None`` without such a frame."""
        cp = (self.simulation.get("support") or {}).get("contact_phase") or {}
        value = cp.get("outside_support_mean")
        return float(value) if isinstance(value, (int, float)) and cp.get("frames") else None


def physics_modes(results: Sequence[InteractionResult]) -> str:
    """The distinct physics modes of ``results``, sorted and joined by "; " ("" for no result)."""
    return "; ".join(sorted({r.physics_mode for r in results}))


def held_out(items: list, n_test: int) -> tuple[list, list]:
    """Split ``items`` into (train, test): up to ``n_test`` test instances of the last actor pairs (sorted),
    whose pairs never appear in training."""
    pairs = sorted({tuple(sorted(i.actors)) for i in items})
    test_pairs: set[tuple[str, ...]] = set()
    test: list = []
    for pair in reversed(pairs):
        if len(test) >= n_test:
            break
        test_pairs.add(pair)
        test = [i for i in items if tuple(sorted(i.actors)) in test_pairs]
    train = [i for i in items if tuple(sorted(i.actors)) not in test_pairs]
    return train, test[:n_test]


def run_interaction(
    dataset: Dataset, label: str, out: Path, config: DemoConfig, progress: Progress | None = None
) -> InteractionResult:
    """Run the loop for one interaction, writing figures and the video into ``out``."""
    say = progress or (lambda _msg: None)
    seconds: dict[str, float] = {}
    items = list(dataset.of_label(label))
    train, test = held_out(items, config.n_test)
    rng = np.random.default_rng(config.seed)
    # The human is a replayed recording and the baselines read all of it: synthesize as the evaluation does.
    synthesis = SynthesisConfig.offline()
    n_obs = synthesis.n_observed

    say(f"{label}: learning sub-events and joint groupings from {len(train)} instances (Algorithm 1)")
    tic = time.perf_counter()
    model = SocialAffordanceModel(learning=LearningConfig(iterations=config.iterations)).fit(train, rng=rng)
    body = BodyFitter().fit_interactions(train, agent=1, rng=rng)
    model.save(out / f"{label}_model.npz")
    groupings = draw_groupings(model, out / f"{label}_groupings.png")
    seconds["learning"] = time.perf_counter() - tic

    say(f"{label}: synthesizing the reaction to {len(test)} held-out humans and fitting the baselines")
    tic = time.perf_counter()
    errors: dict[str, list[float]] = {"full": []}
    shown = test[0]
    for k, inter in enumerate(test):
        keys, skel, subs, _ = synthesize(
            model, observed_part(inter, n_obs), rng=np.random.default_rng(config.seed + k), body=body, config=synthesis
        )
        pred = Prediction(joints=skel, key_joints=keys, subevents=subs, n_observed=n_obs)
        errors["full"].append(key_joint_error(pred, inter))
        if inter is shown:
            frame = instance_frame(inter)
            synthesis_png = plot_key_joint_tracks(
                out / f"{label}_synthesis.png", inter.fps,
                frame.to_canonical(inter.key_joints()[:, 1]), frame.to_canonical(keys), subs, model.subevent_names_,
                human=frame.to_canonical(inter.key_joints()[:, 0]), n_observed=n_obs,
                title=f"{label} {inter.instance_id}: agent 1, ground truth vs synthesized",
            )
    for name in config.baselines:
        method = get_method(name)().fit(train, rng=np.random.default_rng(config.seed))
        errors[name] = [
            key_joint_error(method.predict(observed_part(i, n_obs), n_observed=n_obs, rng=np.random.default_rng(config.seed)), i)
            for i in test
        ]
    seconds["synthesis_and_baselines"] = time.perf_counter() - tic

    say(f"{label}: retargeting onto the {config.robot!r} robot with mink and simulating in MuJoCo")
    tic = time.perf_counter()
    task = task_for_label(label)
    robot = load_robot(config.robot, mjcf=config.mjcf)
    physics = SimConfig.mode(config.physics or robot.physics)
    if not config.contact_completion:
        physics = dataclasses.replace(physics, contact_completion=None)
    reference = run_episode(Simulator(robot, task, physics), GroundTruthSource(), shown)
    sim = Simulator(robot, task, physics)
    # The robot reacts causally: at frame t the synthesis reads the person's frames up to t only.
    source = ModelSource(model, seed=config.seed, config=SynthesisConfig.reactive())
    video = sheet = None
    note = "disabled"
    if config.video:
        try:
            recorder = EpisodeRecorder(sim, out / f"{label}.mp4", out / f"{label}_sheet.png",
                                       width=config.width, height=config.height)
        except RenderingUnavailableError as exc:
            recorder, note = None, f"not rendered: {exc}"
        if recorder is not None:
            with recorder:
                simulation = run_episode(sim, source, shown, on_frame=recorder)
            video, sheet, note = f"{label}.mp4", f"{label}_sheet.png", "rendered"
        else:
            simulation = run_episode(sim, source, shown)
    else:
        simulation = run_episode(sim, source, shown)
    seconds["simulation"] = time.perf_counter() - tic
    return InteractionResult(
        label=label,
        instance=shown.instance_id,
        subevents=[(n, float(d)) for n, d in zip(model.subevent_names_, model.mean_durations_, strict=True)],
        groupings_png=groupings.name,
        synthesis_png=synthesis_png.name,
        errors={k: float(np.mean(v)) for k, v in errors.items()},
        n_test=len(test),
        simulation=simulation,
        reference=reference,
        video=video,
        contact_sheet=sheet,
        video_note=note,
        seconds=seconds,
    )
