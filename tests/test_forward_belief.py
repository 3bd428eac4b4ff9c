"""The forward belief over (sub-event, elapsed duration) against brute-force enumeration of every parse,
and its memory bounded on a stream longer than its horizon."""

from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest
from scipy.special import logsumexp

from socialaff_sim.data.dataset import Dataset
from socialaff_sim.errors import ConfigError, ModelError
from socialaff_sim.inference.forward_belief import ForwardBelief
from socialaff_sim.inference.online_parse import closed_scores, log_duration_survival
from socialaff_sim.learning import SocialAffordanceModel
from socialaff_sim.model.joints import canonical_joints, instance_frame

from conftest import labelled_partitions


def _track(inter) -> np.ndarray:  # noqa: ANN001
    return canonical_joints(inter, instance_frame(inter))


def _brute(model, track: np.ndarray, fps: float, t: int, stride: int) -> dict[tuple[int, int], float]:  # noqa: ANN001
    """P(last start, last label | frames < t) by summing exp(parse score) over every labelled parse on the grid."""
    cfg = model.config
    S = model.n_subevents_
    grid = list(range(0, t, stride)) + [t]
    B = len(grid) - 1
    trans = np.array(model.log_transitions_, float)
    start = model.log_start_probs_
    # Every closed interval's scores, from the parse's own scoring function (one call per grid pair).
    closed = {(a, b): closed_scores(model, track, fps, np.array([a]), np.array([b]))[0]
              for i, a in enumerate(grid[:-1]) for b in grid[i + 1 : -1]}
    surv = {a: [log_duration_survival(model, s, np.array([(t - a) / fps]))[0] for s in range(S)] for a in grid[:-1]}
    acc: dict[tuple[int, int], list[float]] = {}
    for pts, labels in labelled_partitions(B, S, distinct=cfg.distinct_neighbours, unique=cfg.unique_labels):
        score = start[labels[0]]
        for k, lab in enumerate(labels[:-1]):
            a, b = grid[pts[k]], grid[pts[k + 1]]
            score += closed[a, b][lab]
            score += trans[lab, labels[k + 1]]
        a = grid[pts[-2]]
        score += surv[a][labels[-1]]
        acc.setdefault((a, labels[-1]), []).append(score)
    total = logsumexp([logsumexp(v) for v in acc.values()])
    return {k: float(np.exp(logsumexp(v) - total)) for k, v in acc.items()}


@pytest.mark.parametrize("unique", [True, False])
def test_forward_posterior_equals_brute_force_enumeration(shake8: Dataset, shake8_model: SocialAffordanceModel, unique: bool) -> None:
    model = copy.copy(shake8_model)
    model.config = dataclasses.replace(model.config, unique_labels=unique)
    inter = list(shake8)[7]
    track = _track(inter)
    stride, t = 6, 29  # cuts 0, 6, 12, 18, 24 and the open end 29
    fb = ForwardBelief(model, inter.fps, stride=stride, horizon=60)
    fb.advance(track, t)
    starts, post = fb.posterior(t)
    ref = _brute(model, track, inter.fps, t, stride)
    got = {(int(a), s): float(post[k, s]) for k, a in enumerate(starts) for s in range(model.n_subevents_)}
    keys = set(ref) | {k for k, v in got.items() if v > 1e-12}
    for key in keys:
        assert got.get(key, 0.0) == pytest.approx(ref.get(key, 0.0), abs=1e-9), key
    assert post.sum() == pytest.approx(1.0)
    # The mass spreads over several (start, label) states: a test on a one-hot posterior would prove little.
    assert sorted(ref.values())[-2] > 1e-6


def test_forward_belief_is_incremental(shake8: Dataset, shake8_model: SocialAffordanceModel) -> None:
    """Advancing frame by frame gives the same posterior as one advance to the same frame."""
    inter = list(shake8)[7]
    track = _track(inter)
    a = ForwardBelief(shake8_model, inter.fps, stride=3, horizon=30)
    b = ForwardBelief(shake8_model, inter.fps, stride=3, horizon=30)
    for t in range(1, 50):
        a.advance(track, t)
    b.advance(track, 49)
    np.testing.assert_allclose(a.posterior(49)[1], b.posterior(49)[1])


def test_forward_memory_is_bounded_on_a_long_stream(shake8: Dataset, shake8_model: SocialAffordanceModel) -> None:
    parts = [_track(i) for i in list(shake8)[6:]] * 4
    track = np.concatenate(parts)
    fps = list(shake8)[0].fps
    fb = ForwardBelief(shake8_model, fps, stride=2, horizon=20)
    held = []
    ts = range(1, track.shape[0], 7)
    for t in ts:
        fb.advance(track, t)
        starts, post = fb.posterior(t)
        assert np.isfinite(post).all() and post.sum() == pytest.approx(1.0)
        assert (starts < t).all() and (starts >= t - fb.horizon).all()
        held.append(fb.memory)
    assert track.shape[0] > 5 * fb.horizon
    assert max(held) <= fb.n_starts == 10
    assert fb.cuts == (ts[-1] - 1) // 2 + 1  # every cut before the last frame, each once


def test_forward_belief_errors(shake8_model: SocialAffordanceModel) -> None:
    with pytest.raises(ConfigError, match="belief_stride"):
        ForwardBelief(shake8_model, 10.0, stride=0, horizon=10)
    with pytest.raises(ConfigError, match="belief_horizon"):
        ForwardBelief(shake8_model, 10.0, stride=5, horizon=2)
    fb = ForwardBelief(shake8_model, 10.0, stride=2, horizon=10)
    with pytest.raises(ModelError, match="advance"):
        fb.posterior(5)


def test_type_tables_equal_the_models_potentials(shake8_model: SocialAffordanceModel, rng: np.random.Generator) -> None:
    from socialaff_sim.inference.type_tables import TypeTables

    m = shake8_model
    tab = TypeTables(m)
    ends = rng.normal(scale=0.5, size=(30, 11, 3))
    ends[3, 7] = np.nan  # a missing joint: −inf where a type reads it, untouched elsewhere
    disp = rng.normal(scale=0.2, size=(30, 11, 3))
    for s in range(m.n_subevents_):
        np.testing.assert_allclose(tab.spatial(ends, s), m.log_spatial(s, ends), rtol=1e-10)
        np.testing.assert_allclose(tab.spatial(ends)[:, s], m.log_spatial(s, ends), rtol=1e-10)
        np.testing.assert_allclose(tab.motion(disp, s), m.log_motion(s, disp), rtol=1e-10)
        np.testing.assert_allclose(tab.duration(np.array([0.3, 1.2]))[:, s], m.log_duration(s, np.array([0.3, 1.2])), rtol=1e-12)


def test_long_bucket_forgets_used_labels_so_a_stream_can_start_again(shake8: Dataset, shake8_model: SocialAffordanceModel) -> None:
    """With unique labels, the long bucket keeps only its own label in the used set: on a stream of repeated
    instances the belief comes back to the first sub-events instead of staying in the last one."""
    assert shake8_model.config.unique_labels
    one = [_track(i) for i in list(shake8)[6:8]]
    track = np.concatenate(one * 3)
    fps = list(shake8)[0].fps
    fb = ForwardBelief(shake8_model, fps, stride=2, horizon=20)
    tops = []
    for t in range(1, track.shape[0]):
        fb.advance(track, t)
        tops.append(int(np.argmax(fb.belief(t))))
        finite = np.argwhere(np.isfinite(fb._long))
        assert all(m == 1 << s for m, s in finite)  # one used label per long entry: its own
    first = tops[: track.shape[0] // 6]
    last = tops[-track.shape[0] // 3 :]
    assert first[5] in last  # the opening sub-event comes back in the last repetition
    assert len(set(last)) >= 2
