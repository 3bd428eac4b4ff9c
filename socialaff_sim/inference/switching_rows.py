"""The switching regression's rows: what the synthesizer gave on an instance (:class:`Trace`), and the columns,
rows, scales and priors the regression reads (:mod:`.switching` documents the groups).

Column layout of :func:`switching_rows` with S sub-event types and F = :data:`~.reaction_features.N_FEATURES`
motion features: the motion features (F), ``subevent`` (S), ``phase`` (S), ``gated`` (S·F), ``plan`` (15),
``primitive`` (15). The training rows (:func:`instance_rows`) and the reactor (:mod:`.methods`) build them alike.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..data.interaction import Interaction
from ..data.skeletons import N_KEY
from .reaction_features import FEATURE_GROUPS, N_FEATURES, RAMP_COLUMN, Anchor, FeatureConfig, group_columns, nan_to_zero, training_rows
from .reaction_regression import scale_of

__all__ = ["Trace", "instance_rows", "plan_displacement", "plan_offset", "switching_columns", "switching_rows", "switching_scale"]

@dataclass(frozen=True, eq=False)
class Trace:
    """What the synthesizer gave for every frame of one instance (frames < T0 unused)."""

    belief: np.ndarray
    """(T, S) float64: the step's belief over the running sub-event (sums to one)."""
    phase: np.ndarray
    """(T,) float64 in [0, 1]: elapsed fraction of the running sub-event (NaN while observed)."""
    plan: np.ndarray
    """(T, 5, 3) float64, metres, world: agent 1's key joints as Algorithm 2 synthesized them."""
    skeleton: np.ndarray
    """(T, J, 3) float64, metres, world: agent 1's skeleton fitted to ``plan`` (frames ≥ T0; NaN before)."""
    primitive: np.ndarray | None = None
    """(T, 5, 3) float64, metres, world: agent 1's key joints as the interaction primitive predicts them causally
    (frames ≥ T0; NaN before); ``None``: not computed (the ``primitive`` groups then read zeros: ``hold``)."""
    primitive_skeleton: np.ndarray | None = None
    """(T, J, 3) float64, metres, world: agent 1's skeleton fitted to ``primitive`` (or ``None``)."""


def switching_columns(groups: Sequence[str], n_subevents: int) -> np.ndarray:
    """Column indices (int64) of ``groups`` in the rows of :func:`switching_rows` with S = ``n_subevents``;
    ``gated`` takes the gated copies of the motion groups in ``groups`` only."""
    S, F = n_subevents, N_FEATURES
    motion = group_columns([g for g in groups if g in FEATURE_GROUPS])
    out = [motion]
    if "subevent" in groups:
        out.append(F + np.arange(S))
    if "phase" in groups:
        out.append(F + S + np.arange(S))
    if "gated" in groups:
        out.append((F + 2 * S + F * np.arange(S)[:, None] + motion[None]).reshape(-1))
    if "plan" in groups:
        out.append(F + 2 * S + S * F + np.arange(3 * N_KEY))
    if "primitive" in groups:
        out.append(F + 2 * S + S * F + 3 * N_KEY + np.arange(3 * N_KEY))
    return np.concatenate(out).astype(np.int64)


def switching_rows(
    motion: np.ndarray, belief: np.ndarray, phase: np.ndarray, plan: np.ndarray, primitive: np.ndarray | None = None,
    groups: Sequence[str] | None = None,
) -> np.ndarray:
    """(N, F + 2S + S·F + 30) rows: the motion features (N, F), b·r (N, S), b·φ·r (N, S), the gated motion
    features b_s·x (N, S·F; column F + 2S + s·F + j is b_s·x_j), the plan's displacement (N, 15) and the
    interaction primitive's (N, 15), from the motion features (N, F), the belief (N, S), the phase (N,) (NaN
    counts as 0) and the plan's and the primitive's displacements (N, 15), metres, anchor frame (``primitive``
    ``None``: zeros). ``groups``: when given, the ``subevent``, ``phase`` and ``gated`` columns are computed only
    if among them (else zeros; the reactor passes the groups its blend reads)."""
    x = np.asarray(motion, dtype=np.float64)
    b = np.asarray(belief, dtype=np.float64)
    n, S = b.shape
    ramp = x[:, RAMP_COLUMN]
    every = groups is None
    by_subevent = b * ramp[:, None] if every or "subevent" in groups else np.zeros((n, S))
    if every or "phase" in groups:
        by_phase = b * (nan_to_zero(np.asarray(phase, dtype=np.float64)) * ramp)[:, None]
    else:
        by_phase = np.zeros((n, S))
    gated = (b[:, :, None] * x[:, None, :]).reshape(n, -1) if every or "gated" in groups else np.zeros((n, S * x.shape[1]))
    prim = np.zeros((n, 3 * N_KEY)) if primitive is None else nan_to_zero(primitive)
    return np.concatenate([x, by_subevent, by_phase, gated, nan_to_zero(plan), prim], axis=1)


def switching_scale(rows: np.ndarray, w: np.ndarray, n_subevents: int) -> np.ndarray:
    """(F,) column scales of rows (N, F) of :func:`switching_rows` under row weights w (N,): each motion and plan
    column its weighted RMS (:func:`~.reaction_regression.scale_of`); the belief-weighted columns the RMS of the
    column they weight (``subevent`` and ``phase``: the ramp's; ``gated``: the motion column's). So the belief
    stays a weight in [0, 1]: a sub-event the training rows rarely believed in gets no inflated column (its
    own RMS would be near zero, and a test row that believes in it would blow up)."""
    S, F = n_subevents, N_FEATURES
    scale = scale_of(rows, w)
    scale[F:F + 2 * S] = scale[RAMP_COLUMN]
    scale[F + 2 * S:F + 2 * S + S * F] = np.tile(scale[:F], S)
    return scale


def plan_displacement(anchor: Anchor, plan: np.ndarray, interaction: Interaction, *, keys: np.ndarray | None = None) -> np.ndarray:
    """(N, 15) metres, anchor frame: the planned key joints (N, 5, 3) world minus agent 1's at the anchor
    (0 where either is unknown). ``keys``: agent 1's key joints at the anchor (5, 3), world, when already known
    (``interaction.layout.key_joints(anchor.pose[None])[0]``, what is used otherwise)."""
    if keys is None:
        keys = interaction.layout.key_joints(anchor.pose[None])[0]
    d = (np.asarray(plan, dtype=np.float64) - keys[None]) @ anchor.frame.rotation
    return nan_to_zero(d).reshape(len(d), -1)


def plan_offset(anchor: Anchor, skeleton: np.ndarray) -> np.ndarray:
    """(N, J·3) metres, anchor frame: the plan's skeletons (N, J, 3) world minus agent 1's at the anchor (0 where
    either is unknown): the ``from_plan`` prior."""
    d = (np.asarray(skeleton, dtype=np.float64) - anchor.pose[None]) @ anchor.frame.rotation
    return nan_to_zero(d).reshape(len(d), -1)


def instance_rows(
    interaction: Interaction, trace: Trace, n_observed: int, config: FeatureConfig, *, stride: int = 1
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rows (N, ·) of :func:`switching_rows`, targets (N, J·3) (anchor-frame displacements, metres), the
    ``from_plan`` prior (N, J·3) and the ``from_primitive`` prior (N, J·3; zeros without the primitive) of
    frames T0, T0 + ``stride``, … < T of a training instance (``SwitchingConfig.row_stride``; 1: every frame ≥ T0)."""
    X, Y, frames = training_rows(interaction, n_observed, config)
    if stride != 1:  # every stride-th row (the features of a row do not depend on the others)
        X, Y, frames = X[::stride], Y[::stride], frames[::stride]
    anchor = Anchor.from_view(interaction.hide_agent_after(1, n_observed), n_observed, config)
    plan = plan_displacement(anchor, trace.plan[frames], interaction)
    prim = None if trace.primitive is None else plan_displacement(anchor, trace.primitive[frames], interaction)
    rows = switching_rows(X, trace.belief[frames], trace.phase[frames], plan, prim)
    skel = trace.primitive_skeleton
    prim_offset = np.zeros_like(Y) if skel is None else plan_offset(anchor, skel[frames])
    return rows, Y, plan_offset(anchor, trace.skeleton[frames]), prim_offset
