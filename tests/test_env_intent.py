"""The environment passes the model's intent to touch to the simulator as ``socialaff-sim simulate`` does
(retarget.intent.ContactIntent read by both ModelAdapter and ModelSource): the same flags frame by frame, the same
contact states in physics, and without the flags the episode is a different one."""

from __future__ import annotations

from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest
from conftest import check_env_strict

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.environment import AdapterFrame, GroundTruthAdapter, ModelAdapter, SocialAffordanceEnv
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.model.contact_keys import ContactKeys
from socialaff_sim.retarget.intent import NO_INTENT, ContactIntent, TouchIntent
from socialaff_sim.retarget.model_source import ModelSource
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.simulator import SimConfig, Simulator


@pytest.fixture(scope="module")
def high_five():  # noqa: ANN201
    """A high-five model fitted on six synthetic instances (3 MCMC iterations, seed 0) and a seventh, held out:
    its strike is a contact keyframe, so intent capture and the approach apply."""
    data = list(generate_dataset(0, SyntheticConfig(interactions=("high_five",), instances_per_interaction=8)))
    model = SocialAffordanceModel(learning=LearningConfig(iterations=3)).fit(data[:6], rng=np.random.default_rng(0))
    return model, data[6]


def _spy(sim: Simulator, log: list[tuple]) -> None:
    """Record (frame, sub-event, intent flags) of every ``sim.retarget`` call."""
    retarget = sim.retarget

    def recorded(keys, frame=None, subevent=None, contact=False, contact_inside=False,  # noqa: ANN001, ANN202
                 contact_inside_next=False):
        log.append((frame, subevent, contact, contact_inside, contact_inside_next))
        return retarget(keys, frame=frame, subevent=subevent, contact=contact, contact_inside=contact_inside,
                        contact_inside_next=contact_inside_next)

    sim.retarget = recorded  # type: ignore[method-assign]


def _env_episode(inter, adapter) -> tuple[list[tuple], list[bool], SocialAffordanceEnv]:  # noqa: ANN001
    """One zero-residual episode, one step per frame, the simulator's default physics (as ``simulate`` runs):
    the retarget calls and the sub-goal's contact now after every step."""
    env = SocialAffordanceEnv(data=[inter], adapter=adapter, action_mode="residual", control_dt=None,
                              sim_config=SimConfig())
    log: list[tuple] = []
    _spy(env._sims[inter.label], log)
    env.reset(seed=3)
    now = []
    while True:
        _, _, term, trunc, info = env.step(np.zeros((5, 3), np.float32))
        now.append(info["subgoals_now"]["hands_meet"])
        if term or trunc:
            return log, now, env


class _WithoutIntent(ModelAdapter):
    """The model adapter with its intent dropped (what the environment passed before it read the intent)."""

    def observe(self, t: int) -> AdapterFrame:
        return super().observe(t)._replace(intent=NO_INTENT)


def test_env_and_simulate_pass_the_same_intent_and_reach_the_same_contacts(high_five) -> None:  # noqa: ANN001
    model, inter = high_five
    log, now, env = _env_episode(inter, ModelAdapter({"high_five": model}))
    # simulate's loop: the model's synthesis as a source, seeded as the env seeded its adapter.
    sim = Simulator("ours", "high_five", SimConfig.harness())
    sim_log: list[tuple] = []
    _spy(sim, sim_log)
    metrics = run_episode(sim, ModelSource(model, seed=env._adapter_seed), inter)
    assert log == sim_log  # every frame: the same sub-event and the same three flags
    flags = np.array([f[2:] for f in log])
    assert flags[:, 0].any() and flags[:, 1].any() and flags[:, 2].any()  # the strike: intent applies here
    assert not flags[:10].any()  # T0 copied frames: no sub-event inferred, no intent
    # The same physics, so the same contact states frame by frame and the same outcome.
    assert now == metrics["subgoals"][0]["in_contact_per_frame"]
    assert env.simulator.scorer.subgoals[0].success == metrics["subgoals"][0]["success"]
    assert env.simulator.scaler.stand_cap == sim.scaler.stand_cap
    assert np.isfinite(sim.scaler.stand_cap)  # the robot moved in toward the raised hand
    # Without the flags the env plays another episode (the robot stays where the model puts it).
    log_off, now_off, env_off = _env_episode(inter, _WithoutIntent({"high_five": model}))
    assert not np.array([f[2:] for f in log_off]).any()
    assert now_off != now
    assert not np.isfinite(env_off.simulator.scaler.stand_cap)


def test_the_adapter_frame_carries_the_models_intent_per_frame(high_five) -> None:  # noqa: ANN001
    model, inter = high_five
    adapter = ModelAdapter({"high_five": model})
    adapter.reset(inter, rng=np.random.default_rng(7))
    source = ModelSource(model, seed=7)
    source.reset(inter)
    table = ContactIntent.of(model)
    for t in range(inter.n_frames):
        frame, target = adapter.observe(t), source.targets(t)
        assert frame.intent == TouchIntent(target.contact, target.contact_inside, target.contact_inside_next)
        assert frame.intent == table.at(frame.subevent)
    # The recording carries no model, so no intent (as simulate's --source gt).
    gt = GroundTruthAdapter()
    gt.reset(inter)
    assert all(gt.observe(t).intent == NO_INTENT for t in range(inter.n_frames))


def test_intent_lookup_reads_the_current_type_and_nothing_for_an_unknown_one() -> None:
    S = 3
    keys = ContactKeys.empty(S)
    keys.phase[1, 2] = 0.5  # type 1's touch is a keyframe inside it; 0 → 1 is 0's likeliest transition
    ends = np.full((S, 11, 3), 10.0) * np.arange(11)[None, :, None]
    ends[2, 7] = ends[2, 2] + (0.05, 0.0, 0.0)  # type 2 ends with agent 1's right wrist at agent 0's
    trans = np.array([[0.0, 0.8, 0.2], [0.1, 0.0, 0.9], [0.6, 0.4, 0.0]])
    intent = ContactIntent.of(SimpleNamespace(mean_end_=ends, contact_keys_=keys, transitions_=trans))
    assert intent.at(0) == TouchIntent(False, False, True)
    assert intent.at(1) == TouchIntent(True, True, True)
    assert intent.at(2) == TouchIntent(True, False, False)
    assert intent.at(-1) == NO_INTENT and intent.at(S) == NO_INTENT
    assert intent.at(1).kwargs() == {"contact": True, "contact_inside": True, "contact_inside_next": True}


def test_env_checker_clean_with_a_model(high_five) -> None:  # noqa: ANN001
    model, inter = high_five
    env = gym.make("SocialAffordance-v0", data=[inter], model={"high_five": model}, action_mode="residual",
                   max_frames=16)
    try:
        check_env_strict(env)
    finally:
        env.close()
