"""Generate the synthetic dataset: actors, actor pairs, instances, placement and corruption.

Seeding scheme (all streams derive from one integer ``seed`` through
:class:`numpy.random.SeedSequence` spawn keys, so each part is independent of
which other parts are generated):

* actors: ``SeedSequence(seed, spawn_key=(0,))``;
* actor pairs of interaction c: ``SeedSequence(seed, spawn_key=(1 + k,))``,
  with k = ``INTERACTIONS.index(c)``;
* instance i of interaction c: ``SeedSequence(seed, spawn_key=(1 + k, i))``,
  whose generator :func:`generate_instance` splits with ``Generator.spawn(3)``
  into the motion stream (frame rate, timing, choreography), the placement
  stream (room offset and heading) and the noise stream.

Hence generating a subset of the interactions, more instances per interaction,
or other noise levels leaves the rest unchanged, and ``noise=False`` gives
exactly the clean version of the noisy data.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ...errors import ConfigError, choices
from ..dataset import Dataset
from ..interaction import Interaction
from ..skeletons import get_layout
from .body import Actor, make_actors
from .config import INTERACTIONS, SUBEVENTS, SyntheticConfig
from .greetings import script_high_five, script_shake_hands
from .hand_over import script_hand_over
from .ik import rot_z
from .noise import corrupt_joints, corrupt_object
from .pull_up import script_pull_up
from .scripted import Scripted
from .throw_catch import script_throw_catch

__all__ = ["SCRIPTS", "generate_dataset", "generate_instance", "generate_actors", "actor_pairs", "place_in_room"]

ScriptFn = Callable[[tuple[Actor, Actor], float, np.random.Generator, SyntheticConfig], Scripted]

SCRIPTS: dict[str, ScriptFn] = {
    "shake_hands": script_shake_hands,
    "high_five": script_high_five,
    "pull_up": script_pull_up,
    "throw_catch": script_throw_catch,
    "hand_over": script_hand_over,
}
"""The choreography of each interaction: ``(actors, fps, rng, config) -> Scripted`` in the stage frame."""

_LAYOUT = get_layout("kinect_v2")


def _seed_sequence(seed: int, *key: int) -> np.random.SeedSequence:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ConfigError(f"seed: expected a non-negative integer, found {seed!r}")
    return np.random.SeedSequence(int(seed), spawn_key=key)


def generate_actors(seed: int = 0, config: SyntheticConfig | None = None) -> tuple[Actor, ...]:
    """The actors of the dataset generated with ``seed`` (ids ``a01``...; see :func:`.body.make_actors`)."""
    config = SyntheticConfig() if config is None else config
    return make_actors(np.random.default_rng(_seed_sequence(seed, 0)), config)


def actor_pairs(n_actors: int, n_pairs: int, rng: np.random.Generator) -> list[tuple[int, int]]:
    """``n_pairs`` distinct ordered pairs of actor indices, spread evenly over the actors.

    Pairs are taken round by round from a round-robin schedule (circle method)
    of shuffled actors, in shuffled round order, so that every actor appears
    about equally often; the order within each pair is random. Capped at
    ``n_actors·(n_actors − 1)/2`` pairs.
    """
    players = [int(a) for a in rng.permutation(n_actors)] + ([-1] if n_actors % 2 else [])
    m = len(players)
    rounds = []
    for _ in range(m - 1):
        rounds.append([(players[i], players[m - 1 - i]) for i in range(m // 2)])
        players = [players[0], players[-1], *players[1:-1]]
    pairs: list[tuple[int, int]] = []
    for r in rng.permutation(len(rounds)):
        for a, b in rounds[r]:
            if a >= 0 and b >= 0:
                pairs.append((a, b) if rng.random() < 0.5 else (b, a))
    return pairs[: max(1, n_pairs)]


def place_in_room(
    scripted: Scripted, rng: np.random.Generator, half_extent: float
) -> tuple[np.ndarray, np.ndarray | None]:
    """Turn the stage by a uniform yaw and shift it by a uniform offset in [−E, E]² (z untouched).

    Returns the (T, 2, J, 3) joints and the (T, 3) object track (or ``None``) in the room frame, metres.
    """
    yaw = rng.uniform(-np.pi, np.pi)
    offset = np.array([*rng.uniform(-half_extent, half_extent, 2), 0.0])
    rot = rot_z(yaw)
    joints = scripted.joints @ rot.T + offset
    obj = None if scripted.object is None else scripted.object @ rot.T + offset
    return joints, obj


def generate_instance(
    label: str,
    actors: tuple[Actor, Actor],
    rng: np.random.Generator,
    config: SyntheticConfig | None = None,
    *,
    instance_id: str = "",
    source: str = "",
) -> Interaction:
    """Script, place and (unless ``config.noise`` is False) corrupt one interaction instance.

    Args:
        label: one of :data:`INTERACTIONS`.
        actors: (agent 0 = the observed human, agent 1 = the agent a robot will play); must differ.
        rng: the only source of randomness; split with ``rng.spawn(3)`` into motion,
            placement and noise streams (the clean and noisy versions share the motion).
        config: generation settings (defaults: :class:`SyntheticConfig`).
        instance_id, source: stored in the :class:`Interaction`.

    Returns:
        An :class:`Interaction` with Kinect v2 joints (T, 2, 25, 3) in metres, z up,
        floor at z = 0, per-frame ground-truth sub-events named by ``SUBEVENTS[label]``,
        and for ``throw_catch`` / ``hand_over`` the ball / cup centre as object track.
    """
    config = SyntheticConfig() if config is None else config
    if label not in SCRIPTS:
        raise ConfigError(f"generate_instance: unknown interaction {label!r}; expected {choices(INTERACTIONS)}")
    if len(actors) != 2 or actors[0].actor_id == actors[1].actor_id:
        found = tuple(a.actor_id for a in actors)
        raise ConfigError(f"generate_instance: expected two different actors, found {found}")
    motion_rng, place_rng, noise_rng = rng.spawn(3)
    lo, hi = config.fps_range
    fps = float(np.clip(round(motion_rng.uniform(lo, hi), 2), lo, hi))  # a rate like 12.37 fps
    scripted = SCRIPTS[label]((actors[0], actors[1]), fps, motion_rng, config)
    joints, obj = place_in_room(scripted, place_rng, config.room_half_extent)
    valid = None
    if config.noise:
        joint_rng, object_rng = noise_rng.spawn(2)
        joints, valid = corrupt_joints(joints, scripted.occluded, joint_rng, config)
        obj = None if obj is None else corrupt_object(obj, object_rng, config)
    return Interaction(
        label=label,
        fps=fps,
        joints=joints,
        joint_names=_LAYOUT.joint_names,
        actors=(actors[0].actor_id, actors[1].actor_id),
        object=obj,
        valid=valid,
        subevents=scripted.timeline.labels(),
        subevent_names=SUBEVENTS[label],
        source=source,
        instance_id=instance_id,
    )


def generate_dataset(seed: int = 0, config: SyntheticConfig | None = None) -> Dataset:
    """The embedded synthetic HHOI-like dataset (name ``"synthetic"``), bit-identical for a given seed.

    ``config.instances_per_interaction`` instances of each of ``config.interactions``
    (in :data:`INTERACTIONS` order), with ids ``<label>_<index:03d>``. Instance i of
    an interaction uses actor pair ``i mod P`` of its P pairs (see
    :func:`actor_pairs`), with the roles swapped on every other round through the pairs.
    ``Dataset.notes`` records the seed, whether noise was added and each actor's stature.
    """
    config = SyntheticConfig() if config is None else config
    actors = generate_actors(seed, config)
    interactions = []
    for k, label in enumerate(INTERACTIONS):
        if label not in config.interactions:
            continue
        n = config.instances_per_interaction
        pair_rng = np.random.default_rng(_seed_sequence(seed, 1 + k))
        pairs = actor_pairs(len(actors), min(config.pairs_per_interaction, n), pair_rng)
        for i in range(n):
            a, b = pairs[i % len(pairs)]
            if (i // len(pairs)) % 2:
                a, b = b, a
            rng = np.random.default_rng(_seed_sequence(seed, 1 + k, i))
            interactions.append(
                generate_instance(
                    label,
                    (actors[a], actors[b]),
                    rng,
                    config,
                    instance_id=f"{label}_{i:03d}",
                    source=f"synthetic seed={seed} {label} #{i}",
                )
            )
    notes: dict[str, float | str] = {"seed": str(seed), "noise": "on" if config.noise else "off"}
    notes.update({f"height_{a.actor_id}": round(a.height, 4) for a in actors})
    return Dataset("synthetic", tuple(interactions), notes)
