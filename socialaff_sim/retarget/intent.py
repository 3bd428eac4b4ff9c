"""The affordance model's intent to touch, frame by frame: what a model-driven robot passes to the simulator.

A fitted model knows, per sub-event type, whether its agent 1 makes a hand contact in it
(:func:`~socialaff_sim.model.contact_keys.contact_types`), whether that contact is a keyframe inside the
interval released before its end (a high five's strike: the type has a contact keyframe), and whether the type
or its likeliest successor (``transitions_``) has such a keyframe contact. :class:`ContactIntent` holds these
three (S,) tables; :meth:`ContactIntent.at` reads them for the synthesizer's current sub-event, so a frame's
intent depends only on the sub-event inferred from the person's frames up to that frame (causal whenever the
synthesis is). Both drivers of the simulator read it here, so they pass the same flags for the same synthesis:
:class:`~socialaff_sim.retarget.model_source.ModelSource` (``socialaff-sim simulate``, the demo) and the
environment's :class:`~socialaff_sim.environment.model_adapter.ModelAdapter`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np

from ..model.contact_keys import contact_types

__all__ = ["TouchIntent", "NO_INTENT", "ContactIntent"]


class TouchIntent(NamedTuple):
    """The model's intent to touch at one frame, as :meth:`~socialaff_sim.sim.simulator.Simulator.retarget`
    takes it (its keyword arguments of the same names)."""

    contact: bool = False
    """The current sub-event is one the model makes a hand contact in."""
    contact_inside: bool = False
    """That contact is a keyframe inside the sub-event, released before its end (a high five's strike)."""
    contact_inside_next: bool = False
    """The current sub-event or its likeliest successor has such a keyframe contact (the robot may move in)."""

    def kwargs(self) -> dict[str, bool]:
        """The flags as keyword arguments of ``Simulator.retarget``."""
        return {"contact": self.contact, "contact_inside": self.contact_inside,
                "contact_inside_next": self.contact_inside_next}


NO_INTENT = TouchIntent()
"""No intent to touch: a source without a model (the recording), or a frame whose sub-event is unknown."""


@dataclass(frozen=True)
class ContactIntent:
    """Per sub-event type of a fitted model, its intent to touch (see the module docstring)."""

    touch: np.ndarray
    """(S,) bool: the types that make a hand contact (:func:`~socialaff_sim.model.contact_keys.contact_types`)."""
    inside: np.ndarray
    """(S,) bool: the types whose contact is a keyframe inside the interval (a finite ``contact_keys_.phase``)."""
    inside_next: np.ndarray
    """(S,) bool: ``inside`` of the type or of its likeliest successor (the row maximum of ``transitions_``)."""
    _frames: tuple[TouchIntent, ...] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # One TouchIntent per type, built once: the per-frame lookup is then an index (the env reads it per frame).
        frames = tuple(TouchIntent(bool(a), bool(b), bool(c)) for a, b, c in zip(self.touch, self.inside, self.inside_next))
        object.__setattr__(self, "_frames", frames)

    @classmethod
    def of(cls, model: Any) -> ContactIntent:
        """The tables of a fitted model (anything with ``mean_end_`` (S, 11, 3), ``contact_keys_`` and
        ``transitions_`` (S, S))."""
        inside = np.isfinite(model.contact_keys_.phase).any(axis=1)
        successor = np.argmax(np.asarray(model.transitions_), axis=1)
        return cls(contact_types(model.mean_end_, model.contact_keys_), inside, inside | inside[successor])

    def at(self, subevent: int) -> TouchIntent:
        """The intent at a frame whose current sub-event is type ``subevent`` (:data:`NO_INTENT` when it is
        unknown: negative, as over the synthesis' first T0 frames, or not a type of this model)."""
        return self._frames[subevent] if 0 <= subevent < len(self._frames) else NO_INTENT
