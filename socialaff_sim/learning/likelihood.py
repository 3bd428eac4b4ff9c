"""The potentials' maximized log-likelihood of one sub-event type as a function of its grouping Z^s.

For a fixed set of N samples (the intervals the current parses label s) the log-likelihood
decomposes over joints: a Null joint contributes its exponential/von Mises motion term; an
affordable joint its Weibull/von Mises motion term plus its spatial term, which depends only
on the set of *other* members of its group. The motion terms are fitted once per sample set;
the spatial terms are fitted on demand, batched, and memoized by (joint, other members), so
repeated Gibbs sweeps and proposals that revisit a grouping cost a dictionary look-up.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..model.config import AffordanceConfig
from ..model.joints import N_JOINTS, reference_row
from ..model.potentials import fit_affordable_motion, fit_null_motion, fit_offsets
from .sample_fits import SampleFits

__all__ = ["TypeLikelihood"]


class TypeLikelihood:
    """Maximized log-likelihood of one type's samples for any grouping vector."""

    def __init__(
        self, end: np.ndarray, disp: np.ndarray, available: np.ndarray, cfg: AffordanceConfig, fits: SampleFits | None = None
    ) -> None:
        """``end``, ``disp``: (N, 11, 3) canonical metres; ``available``: (11,) bool; ``fits``: the run's memo of
        this sample set's fits (:mod:`.sample_fits`; the same ``available`` and ``cfg`` at every use), or None."""
        self.end = end
        self.cfg = cfg
        self.available = np.asarray(available, bool)
        self.n = int(end.shape[0])
        self.null_ll = np.zeros(N_JOINTS)
        self.aff_motion_ll = np.zeros(N_JOINTS)
        self._memo: dict[int, float] = {}
        self.group_sums: dict[int, float] = {}
        """Σ of a group's (bitmask's) spatial terms, kept by the Gibbs loop (:mod:`.gibbs`)."""
        self.n_fits = 0
        self.fits = fits
        av = np.flatnonzero(self.available)
        if self.n and av.size:
            if fits is None or fits.motion is None:
                self.null_ll[av] = fit_null_motion(disp[:, av], cfg)[1]
                self.aff_motion_ll[av] = fit_affordable_motion(disp[:, av], cfg)[1]
                if fits is not None:
                    fits.motion = (self.null_ll.copy(), self.aff_motion_ll.copy())
            else:
                self.null_ll[:] = fits.motion[0]
                self.aff_motion_ll[:] = fits.motion[1]

    @staticmethod
    def key(j: int, others: int) -> int:
        """Memo key of joint ``j``'s spatial term with the other members ``others`` (bitmask; 0 = lone)."""
        return (others << 4) | j

    def ensure(self, keys: list[int]) -> None:
        """Fit, in one batch, the spatial terms of the keys the memo lacks."""
        missing = [k for k in keys if k not in self._memo]
        if missing:
            self._compute(missing)

    @property
    def memo(self) -> dict[int, float]:
        """The spatial terms fitted so far by memo key (read it, do not write it): the Gibbs loop's look-ups."""
        return self._memo

    def spatial_term(self, j: int, others: int) -> float:
        """Maximized spatial log-likelihood of joint ``j`` relative to ``others`` (fitted on demand)."""
        return self.term((others << 4) | j)

    def term(self, k: int) -> float:
        """The spatial term of memo key ``k`` (:meth:`key`), fitted on demand."""
        v = self._memo.get(k)
        if v is None:
            self._compute([k])
            v = self._memo[k]
        return v

    def _compute(self, keys: list[int]) -> None:
        """Fit the spatial potentials of the given (joint, others-mask) keys in one batch."""
        keys = [k for k in dict.fromkeys(keys) if k not in self._memo]
        if not keys:
            return
        if self.n == 0:
            for k in keys:
                self._memo[k] = 0.0
            return
        values = self._fit(keys) if self.fits is None else self.fits.batch(tuple(keys), lambda: self._fit(keys))
        self.n_fits += len(keys)
        for k, v in zip(keys, values, strict=True):
            self._memo[k] = v

    def _fit(self, keys: list[int]) -> list[float]:
        """The spatial terms of one batch of keys, fitted together (:func:`fit_offsets`)."""
        js = np.array([k & 15 for k in keys])
        side, own = self.cfg.other_side_reference, self.cfg.reference_self
        W = np.array([_key_reference(k, side, own) for k in keys])
        return fit_offsets(self.end, js, W, self.cfg, with_params=False)[1].tolist()

    @staticmethod
    def _keys_of(z: np.ndarray | list[int]) -> list[int]:
        masks: dict[int, int] = {}
        for j, h in enumerate(z):
            if h > 0:
                masks[h] = masks.get(h, 0) | (1 << j)
        return [TypeLikelihood.key(j, masks[h] & ~(1 << j)) for j, h in enumerate(z) if h > 0]

    def prefetch(self, zs: list[list[int]]) -> None:
        """Fit, in one batch, every spatial term the given grouping vectors need and the memo lacks."""
        self._compute([k for z in zs for k in self._keys_of(z)])

    def loglik(self, z: np.ndarray | list[int]) -> float:
        """Log-likelihood of the samples under grouping ``z`` (11,) (parameters at their ML values)."""
        return float(self.loglik_many([list(z)])[0])

    def loglik_many(self, zs: list[list[int]]) -> np.ndarray:
        """Log-likelihoods of several grouping vectors, fitting missing spatial terms in one batch."""
        key_lists = [self._keys_of(z) for z in zs]
        self._compute([k for ks in key_lists for k in ks])
        out = np.empty(len(zs))
        av = self.available
        for r, (z, ks) in enumerate(zip(zs, key_lists, strict=True)):
            total = 0.0
            for j, h in enumerate(z):
                if av[j]:
                    total += self.aff_motion_ll[j] if h > 0 else self.null_ll[j]
            total += sum(self._memo[k] for k in ks)
            out[r] = total
        return out


@lru_cache(maxsize=None)
def _key_reference(key: int, other_side: bool, include_self: bool) -> np.ndarray:
    """(11,) read-only reference weights of memo key ``key`` (:meth:`TypeLikelihood.key`): a pure function of
    the key and the two settings, so computed once per process."""
    others = key >> 4
    row = reference_row(key & 15, [m for m in range(N_JOINTS) if others >> m & 1], other_side, include_self)
    row.setflags(write=False)
    return row
