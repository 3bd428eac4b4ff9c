"""Contact keyframes: where and when agent 1's hand touches a group mate *inside* a sub-event.

The paper's potentials describe a sub-event by its two end configurations, and synthesis
interpolates between them. A touch that happens in the middle of a sub-event and is released
before its end (a high five's strike meets the other hand and rebounds) is therefore never
reached: at the recorded contact frame the synthesized hand is 0.1–0.4 m short (docs/design.md).

This is our addition. For each sub-event type and each of agent 1's wrists that the learned
grouping places with joints of agent 0 (or the object), the training intervals give the frame of
closest approach to the nearest such mate. When that approach is a contact on average (mean
closest distance below ``radius``) that is not there at the interval's ends (mean distances at its
first and last frame at least ``radius``: a contact at an end is already the end configuration the
potentials describe), the type carries a *contact keyframe* for the wrist: its mean phase in the
interval, the mate it touches most often, the wrist's mean offset from that mate at the contact
(canonical frame), and where that mate then is relative to agent 0's base (mean and RMS spread).
Synthesis pulls the wrist toward ``mate + offset``: offline around the keyframe's phase, causally
while the mate is near its contact pose
(:attr:`~socialaff_sim.inference.synthesis_config.SynthesisConfig.contact`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..data.skeletons import N_KEY
from .joints import OBJECT

__all__ = ["ContactKeys", "Keyframe", "contact_types", "fit_contact_keys", "WRISTS1", "CONTACT_END_RADIUS"]

WRISTS1 = np.array([N_KEY + 1, N_KEY + 2])
"""Model indices of agent 1's wrists, the joints that can carry a contact keyframe (hands are what touch)."""

_MATES = np.r_[np.arange(N_KEY), OBJECT]
_HANDS0 = np.array([1, 2, OBJECT])
"""Model indices of what agent 1's hands meet: agent 0's wrists and the object."""
CONTACT_END_RADIUS = 0.2
"""Metres: an end configuration whose wrist lies this close to agent 0's wrist or the object is a contact."""


class Keyframe(NamedTuple):
    """One learned contact keyframe (see :class:`ContactKeys` for the fields' meaning)."""

    joint: int
    """Model index of agent 1's joint (a wrist)."""
    mate: int
    """Model index of the touched joint."""
    phase: float
    """Mean phase of the touch in its interval."""
    offset: np.ndarray
    """(3,) metres: agent 1's joint minus the mate at the touch."""
    pose: np.ndarray
    """(3,) metres: the mate relative to agent 0's base at the touch."""
    spread: float
    """Metres: RMS spread of ``pose``."""


@dataclass(frozen=True)
class ContactKeys:
    """Learned contact keyframes of agent 1's key joints, per sub-event type."""

    phase: np.ndarray
    """(S, 5) float64: mean phase v ∈ [0, 1] of the contact in its interval (v = (f − start) / (stop − 1 − start)),
    NaN where agent 1's key joint has no contact keyframe in that type."""
    mate: np.ndarray
    """(S, 5) int64: model index of the touched joint (agent 0's key joint or the object), −1 where none."""
    offset: np.ndarray
    """(S, 5, 3) float64, metres, canonical: mean position of agent 1's joint minus its mate's at the contact."""
    pose: np.ndarray
    """(S, 5, 3) float64, metres, canonical: mean position of the mate relative to agent 0's base at the contact."""
    spread: np.ndarray
    """(S, 5) float64, metres: RMS distance of those mate positions from ``pose`` (at least ``radius`` / 2)."""

    @classmethod
    def empty(cls, S: int) -> ContactKeys:
        """No contact keyframe in any of ``S`` types."""
        nan3 = np.full((S, N_KEY, 3), np.nan)
        return cls(np.full((S, N_KEY), np.nan), np.full((S, N_KEY), -1, np.int64), nan3, nan3.copy(), np.full((S, N_KEY), np.nan))

    def of_type(self, s: int) -> list[Keyframe]:
        """The keyframes of type ``s``."""
        k = np.flatnonzero(np.isfinite(self.phase[s]))
        return [
            Keyframe(N_KEY + int(i), int(self.mate[s, i]), float(self.phase[s, i]), self.offset[s, i], self.pose[s, i], float(self.spread[s, i]))
            for i in k
        ]

    def all(self) -> list[Keyframe]:
        """The keyframes of every type."""
        return [key for s in range(self.phase.shape[0]) for key in self.of_type(s)]


def fit_contact_keys(
    grouping: np.ndarray,
    spans: Sequence[Sequence[tuple[int, int, int]]],
    tracks: Sequence[np.ndarray],
    available: np.ndarray,
    radius: float,
) -> ContactKeys:
    """Contact keyframes from the training parses.

    ``grouping``: (S, 11) int Z^s; ``spans``: per instance, (start, stop, label) frame intervals;
    ``tracks``: per instance (T, 11, 3) float64, metres, canonical; ``available``: (11,) bool;
    ``radius``: metres, the mean closest distance below which an approach counts as a contact.
    """
    S = grouping.shape[0]
    keys = ContactKeys.empty(S)
    for s in range(S):
        z = grouping[s]
        for j in WRISTS1:
            if z[j] <= 0 or not available[j]:
                continue
            mates = _MATES[(z[_MATES] == z[j]) & available[_MATES]]
            if mates.size == 0:
                continue
            phases, closest, ends, nearest, offsets, poses = [], [], [], [], [], []  # ends: (first, last) frame
            for x, sp in zip(tracks, spans, strict=True):
                for a, b, lab in sp:
                    if lab != s or b - a < 3:
                        continue
                    d = np.linalg.norm(x[a:b, j][None] - x[a:b][:, mates].transpose(1, 0, 2), axis=-1)  # (M, F)
                    d = np.where(np.isfinite(d), d, np.inf)
                    per_frame = d.min(axis=0)
                    if not np.isfinite(per_frame).any():
                        continue
                    f = int(np.argmin(per_frame))
                    m = int(mates[np.argmin(d[:, f])])
                    phases.append(f / (b - a - 1))
                    closest.append(per_frame[f])
                    ends.append((per_frame[0], per_frame[-1]))
                    nearest.append(m)
                    offsets.append(x[a + f, j] - x[a + f, m])
                    poses.append(x[a + f, m] - x[a + f, 0])
            if not closest:
                continue
            ends_arr = np.asarray(ends)
            ends_arr[~np.isfinite(ends_arr)] = np.nan  # an end frame missing the joint says nothing
            # Released at both ends: each end seen at least once (so its mean is defined), its mean ≥ radius.
            released = np.isfinite(ends_arr).any(axis=0).all() and np.all(np.nanmean(ends_arr, axis=0) >= radius)
            if not (np.mean(closest) < radius and released):
                continue
            near = np.asarray(nearest)
            m = int(np.bincount(near).argmax())
            touches = near == m
            i = j - N_KEY
            keys.phase[s, i] = float(np.mean(phases))
            keys.mate[s, i] = m
            keys.offset[s, i] = np.mean(np.asarray(offsets)[touches], axis=0)
            at = np.asarray(poses)[touches]
            keys.pose[s, i] = np.nanmean(at, axis=0)
            rms = np.sqrt(np.nanmean(np.sum((at - keys.pose[s, i]) ** 2, axis=1)))
            keys.spread[s, i] = max(float(rms), 0.5 * radius)  # one instance (or identical ones) has no spread
    return keys


def contact_types(mean_end: np.ndarray, keys: ContactKeys, radius: float = CONTACT_END_RADIUS) -> np.ndarray:
    """(S,) bool: the sub-event types in which the model's agent 1 makes a hand contact.

    A type makes contact when its mean end configuration ``mean_end`` ((S, 11, 3), metres, the model's
    ``mean_end_``) puts one of agent 1's wrists within ``radius`` of agent 0's wrists or the object (a handshake's
    ``shake``, a catch's ``hold``), or when it carries a contact keyframe (a touch inside the interval released
    before its end: a high five's ``strike``). The simulator reads it as the model's intent to touch
    (:mod:`~socialaff_sim.retarget.contact_completion`)."""
    mean_end = np.asarray(mean_end, dtype=np.float64)
    d = np.linalg.norm(mean_end[:, WRISTS1, None, :] - mean_end[:, None, _HANDS0, :], axis=-1)  # (S, 2, 3)
    d = np.where(np.isfinite(d), d, np.inf)
    return (d.min(axis=(1, 2)) < radius) | np.isfinite(keys.phase).any(axis=1)
