"""Active-hand relabelling: the flags, the relabelling, the coupling, and the model's and synthesizer's
invariance to which side an actor happens to use."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from conftest import swap_sides

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.inference.synthesis import OnlineSynthesizer, SynthesisConfig
from socialaff_sim.learning.config import LearningConfig
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.model.config import AffordanceConfig
from socialaff_sim.model.handedness import fit_hand_coupling, hand_flags, left_active, partner_flag, relabel
from socialaff_sim.model.joints import JOINT_NAMES, canonical_joints


def _travel(track: np.ndarray, name: str, stop: int | None = None) -> float:
    """Summed frame-to-frame distance of one model joint, by a plain loop."""
    j = JOINT_NAMES.index(name)
    x = track[:stop]
    return float(sum(np.linalg.norm(x[t + 1, j] - x[t, j]) for t in range(len(x) - 1)))


def test_flags_follow_the_longer_wrist_path(shake8: Dataset) -> None:
    flags = []
    for inter in shake8:
        x = canonical_joints(inter)
        for a in (0, 1):
            for stop in (None, 15):
                gap = _travel(x, f"agent{a}.left_wrist", stop) - _travel(x, f"agent{a}.right_wrist", stop)
                assert left_active(x, a, stop) == (gap > 0)
                for margin in (0.1, 0.5):
                    assert left_active(x, a, stop, margin) == (gap > margin)
        flags.append(hand_flags(x))
    # Swapping an agent's sides flips its flag and no other.
    x = canonical_joints(swap_sides(shake8[0], [1]))
    np.testing.assert_array_equal(hand_flags(x), flags[0] ^ np.array([False, True]))


def test_flags_read_only_frames_before_stop(shake8: Dataset) -> None:
    x = canonical_joints(shake8[1])
    y = x.copy()
    y[20:, 1] += 5.0  # move agent 0's left wrist far after frame 20
    assert left_active(y, 0, 20) == left_active(x, 0, 20)
    assert left_active(y, 0) is True


def test_relabel_swaps_sides_by_name_and_is_an_involution(rng: np.random.Generator) -> None:
    x = rng.normal(size=(7, len(JOINT_NAMES), 3))
    for flags in ([False, False], [True, False], [False, True], [True, True]):
        y = relabel(x, np.array(flags))
        for j, name in enumerate(JOINT_NAMES):
            agent = int(name[5]) if name.startswith("agent") else None
            src = name
            if agent is not None and flags[agent]:
                src = name.replace("left", "#").replace("right", "left").replace("#", "right")
            np.testing.assert_array_equal(y[:, j], x[:, JOINT_NAMES.index(src)], err_msg=f"{flags} {name}")
        np.testing.assert_array_equal(relabel(y, np.array(flags)), x)


def test_coupling_counts_flag_pairs(rng: np.random.Generator) -> None:
    flags = rng.random((40, 2)) < 0.4
    got = fit_hand_coupling(flags, alpha=1.0)
    for f0 in (0, 1):
        rows = flags[flags[:, 0] == bool(f0)]
        n_left = int(rows[:, 1].sum())
        assert got[f0, 1] == pytest.approx((n_left + 1.0) / (len(rows) + 2.0), abs=1e-12)
        assert got[f0].sum() == pytest.approx(1.0, abs=1e-12)
    assert partner_flag(np.array([[0.8, 0.2], [0.3, 0.7]]), False) is False
    assert partner_flag(np.array([[0.8, 0.2], [0.3, 0.7]]), True) is True
    assert partner_flag(np.array([[0.8, 0.2], [0.6, 0.4]]), True) is False
    assert partner_flag(np.array([[0.5, 0.5], [0.5, 0.5]]), True) is False  # tie: right


def test_fit_is_invariant_to_which_side_each_actor_uses(shake8: Dataset, shake8_model: SocialAffordanceModel) -> None:
    """Swapping sides of random agents of random instances gives the same learned model (active_hand on)."""
    pick = np.random.default_rng(7).random((6, 2)) < 0.5
    print("swapped (instance, agent):", np.argwhere(pick).tolist())
    assert pick.any()
    swapped = [swap_sides(i, np.flatnonzero(p)) for i, p in zip(list(shake8)[:6], pick, strict=True)]
    other = SocialAffordanceModel(learning=LearningConfig(iterations=3)).fit(swapped, rng=np.random.default_rng(0))
    for name in ("grouping_", "spatial_params_", "motion_params_", "duration_params_", "transitions_", "centroids_"):
        np.testing.assert_array_equal(getattr(other, name), getattr(shake8_model, name), err_msg=name)
    for a, b in zip(other.parses_, shake8_model.parses_, strict=True):
        np.testing.assert_array_equal(a, b)
    # Without the relabelling the same swaps change what is learned.
    plain = AffordanceConfig(active_hand=False)
    m0 = SocialAffordanceModel(plain, LearningConfig(iterations=3)).fit(list(shake8)[:6], rng=np.random.default_rng(0))
    m1 = SocialAffordanceModel(plain, LearningConfig(iterations=3)).fit(swapped, rng=np.random.default_rng(0))
    assert not np.array_equal(m0.centroids_, m1.centroids_)
    np.testing.assert_array_equal(m0.reaction_hands(canonical_joints(shake8[6])), [False, False])


def test_offline_synthesis_mirrors_its_labels_when_both_actors_swap_sides(
    shake8: Dataset, shake8_model: SocialAffordanceModel
) -> None:
    """With a 'same side' coupling, swapping both agents' sides swaps agent 1's synthesized joints, and nothing else."""
    model = copy.copy(shake8_model)  # the fixture is shared: change the coupling on a copy
    model.hand_coupling_ = np.array([[0.9, 0.1], [0.1, 0.9]])
    config = SynthesisConfig.offline()
    inter = shake8[7]
    out = {}
    for key, x in (("as recorded", inter), ("swapped", swap_sides(inter, [0, 1]))):
        syn = OnlineSynthesizer(model, None, config)
        syn.reset(x, rng=np.random.default_rng(3))
        out[key] = np.stack([syn.step().key_joints for _ in range(x.n_frames)])
    a, b = out["as recorded"], out["swapped"]
    np.testing.assert_allclose(b, a[:, [0, 2, 1, 4, 3]], rtol=0, atol=1e-12)
    assert not np.allclose(a[:, 1], a[:, 2])  # the wrists differ, so the check can fail


@pytest.mark.parametrize("belief", ["forward", "argmax"])
def test_causal_flag_switches_once_and_keeps_the_emitted_frames(
    shake8: Dataset, shake8_model: SocialAffordanceModel, belief: str
) -> None:
    """Reactive synthesis on an instance whose agent 0 uses the left hand: the flag starts right, turns left
    once the margin is passed (read from frames before t only), agent 1's with it under a 'same side'
    coupling, and agent 1's synthesized wrists go on from where they were."""
    inter = swap_sides(shake8[7], [0])
    config = SynthesisConfig.reactive(belief=belief)
    model = copy.copy(shake8_model)
    model.hand_coupling_ = np.array([[0.9, 0.1], [0.1, 0.9]])
    syn = OnlineSynthesizer(model, None, config)
    syn.reset(inter, rng=np.random.default_rng(5))
    x = canonical_joints(inter)
    flags, keys, plan = [], [], config.n_observed
    for _ in range(inter.n_frames):
        before, planned = syn._hands.copy(), syn._planned_until  # noqa: SLF001 (the state under test)
        step = syn.step()
        keys.append(step.key_joints)
        flags.append(bool(syn._hands[0]))  # noqa: SLF001
        assert syn._hands[1] == syn._hands[0]  # noqa: SLF001
        if before[0] != syn._hands[0]:
            # The switch happens at a re-planning frame t, decided by frames [0, t) with the margin,
            # and was not yet due at the plan before.
            assert syn._planned_until != planned  # noqa: SLF001
            assert left_active(x, 0, step.t, config.hand_margin) and not left_active(x, 0, plan, config.hand_margin)
        if syn._planned_until != planned:  # noqa: SLF001
            plan = step.t
    switches = np.flatnonzero(np.diff(np.array(flags, int)))
    print("flag switches at frames", switches + 1)
    assert switches.size == 1 and not flags[0] and flags[-1]
    # Agent 1's wrists move on continuously across the switch: had its history not been relabelled with
    # it, they would trade places (a jump of about the shoulder width).
    k = int(switches[0]) + 1
    wrists = np.stack(keys)[:, 1:3]
    jump = np.linalg.norm(wrists[k] - wrists[k - 1], axis=-1)
    apart = np.linalg.norm(wrists[k - 1, 0] - wrists[k - 1, 1])
    print(f"wrist steps at the switch {jump} m, wrists {apart:.2f} m apart")
    # A trade would move each wrist by about their separation (0.75 m here). The forward belief re-plans
    # towards the new side over a few frames (steps of 0.12-0.16 m, against 0.09 m at most without the
    # switch), so the bound is a quarter of the separation, not a speed.
    assert jump.max() < apart / 4
