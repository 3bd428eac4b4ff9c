"""What the online synthesizer (:class:`~socialaff_sim.inference.synthesis.OnlineSynthesizer`) emits for one frame."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SynthesisStep"]


@dataclass(frozen=True)
class SynthesisStep:
    """What the synthesizer emits for one frame."""

    t: int
    """Frame index."""
    key_joints: np.ndarray
    """(5, 3) float64, metres, world frame: agent 1's key joints (NaN where the layout lacks one)."""
    skeleton: np.ndarray | None
    """(J, 3) float64, metres, world frame: agent 1's full skeleton, or ``None`` without a body fitter."""
    belief: np.ndarray
    """(S,) float64: belief over the current sub-event: the forward filter's posterior given the frames before
    this one (``belief="forward"``, from frame 1 on), else the DP's max-product weights at the latest re-planning
    (uniform before T0)."""
    subevent: int
    """Index of the current sub-event (−1 while agent 1 is still observed)."""
    subevent_name: str | None
    """Its name, or ``None``."""
    observed: bool
    """True for the first T0 frames, which are copied from the observation."""
    phase: float = float("nan")
    """Elapsed fraction [0, 1] of the running sub-event at this frame, from its start and predicted end at the
    latest re-planning (NaN while agent 1 is still observed)."""
