"""Maximum-likelihood estimates of every learned parameter from parsed, grouped training tracks.

The closing step of learning (and of nothing else): given the final parses and groupings, fit each
sub-event type's potentials, duration prior, path noise, regressions and contact keyframes, and the transition frequencies.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .config import AffordanceConfig
from .contact_keys import fit_contact_keys
from .densities import fit_lognorm
from .end_regression import fit_end_regression, interval_samples
from .features import type_samples
from .frame_regression import fit_frame_regression, frame_samples
from .joints import N_JOINTS
from .path import fit_path_noise
from .potentials import fit_type_potentials
from .ridge import RidgeRegression
from .transitions import count_transitions, smoothed_probs
from .type_stats import vertical_up_frequencies

__all__ = ["estimate_parameters"]


def estimate_parameters(
    grouping: np.ndarray,
    spans: Sequence[Sequence[tuple[int, int, int]]],
    tracks: Sequence[np.ndarray],
    fps: Sequence[float],
    available: np.ndarray,
    config: AffordanceConfig,
) -> dict[str, object]:
    """The learned attributes of :class:`~socialaff_sim.learning.SocialAffordanceModel` that are
    fitted from the data, by name (``spatial_params_``, …, ``frame_regression_``).

    ``grouping``: (S, 11) int Z^s; ``spans``: per instance, (start, stop, label) frame intervals;
    ``tracks``: per instance (T, 11, 3) float64, metres, canonical; ``fps``: per instance, frames/s.
    """
    S = grouping.shape[0]
    cfg = config
    spatial = np.full((S, N_JOINTS, 6), np.nan)
    motion = np.full_like(spatial, np.nan)
    durations = np.full((S, 2), np.nan)
    mean_end = np.full((S, N_JOINTS, 3), np.nan)
    vertical_up = np.full((S, 2, N_JOINTS), 0.5)
    path_sigma = np.full((S, N_JOINTS), np.nan)
    end_regressions: list[RidgeRegression | None] = []
    frame_regressions: list[RidgeRegression | None] = []
    for s in range(S):
        feats = type_samples(tracks, fps, spans, s, cfg.feature_path_profile)
        if len(feats):
            pot = fit_type_potentials(feats.end, feats.disp, grouping[s], cfg)
            spatial[s], motion[s] = pot.spatial, pot.motion
            ln = fit_lognorm(feats.seconds, sigma_min=cfg.sigma_min)
            durations[s] = (ln.mu[0], ln.sigma[0])
            mean_end[s] = feats.end.mean(axis=0)
            vertical_up[s] = vertical_up_frequencies(feats.end, feats.disp, grouping[s], cfg.other_side_reference, cfg.reference_self)
            if feats.path_sq is not None and feats.path_n is not None:
                path_sigma[s] = fit_path_noise(feats.path_sq, feats.path_n, cfg.path_sigma_min, available)[0]
        sig = cfg.end_sigma_min
        ref = cfg.n_observed - 1
        end_regressions.append(fit_end_regression(*interval_samples(tracks, spans, s, ref), available, sigma_min=sig))
        frame_regressions.append(fit_frame_regression(*frame_samples(tracks, spans, s, ref), available, sigma_min=sig))
    start, trans = count_transitions(spans, S)
    start_probs, transitions = smoothed_probs(start, trans, cfg.transition_alpha, cfg.distinct_neighbours, cfg.start_prior)
    return {
        "spatial_params_": spatial,
        "motion_params_": motion,
        "duration_params_": durations,
        "mean_end_": mean_end,
        "vertical_up_": vertical_up,
        "path_sigma_": path_sigma,
        "end_regression_": end_regressions,
        "frame_regression_": frame_regressions,
        "contact_keys_": fit_contact_keys(grouping, spans, tracks, available, cfg.contact_radius),
        "start_probs_": start_probs,
        "transitions_": transitions,
    }
