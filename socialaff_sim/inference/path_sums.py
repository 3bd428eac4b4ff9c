"""Running path-residual sums of intervals that grow at their end: the forward belief's path terms in closed form.

:func:`~socialaff_sim.model.path.path_residuals` scores an interval's interior frames against the straight path
between its ends from all of its frames. The forward belief (:class:`~.forward_belief.ForwardBelief`) scores, at
every cut, the intervals from each of its kept starts to the new cut: the same starts with an end that moves on by
one stride per cut. The squared residual is a quadratic in the end frame. With, for an interval anchored at frame a
(the frame before its start; 0 for a start at 0) and ending at frame e, L = e − a, the interior frames a + k
(k = 1 … L − 1), y_k = x_{a+k} − x_a, D = x_e − x_a and the profile u(v) = Σ_p c_p v^p
(:data:`~socialaff_sim.model.path.PROFILE_POLYNOMIALS`):

    Σ_k ‖y_k − u(k/L) D‖² = Σ_k ‖y_k‖² − 2 D · Σ_p c_p L^(−p) Σ_k k^p y_k + ‖D‖² Σ_k u(k/L)²   (per joint)

so :class:`PathSums` keeps per start the running sums Σ_k ‖y_k‖² and Σ_k k^p y_k and adds only the frames new
since the last call: O(stride × joints) per start and cut instead of O(frames × joints). Exact in arithmetic, not
bitwise (a difference of sums instead of a sum of squares): the tolerance is declared in docs/design.md §7 and
tested against ``path_residuals`` (tests/test_path_sums.py).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError, ModelError
from ..model.path import PROFILE_POLYNOMIALS, profile

__all__ = ["PathSums"]


class PathSums:
    """Per kept start (a row, oldest first), the running sums of its interval's interior frames; the path residuals
    of every row's interval ending at one common frame."""

    def __init__(self, kind: str, n_joints: int) -> None:
        """``kind``: the time profile (a key of :data:`~socialaff_sim.model.path.PROFILE_POLYNOMIALS`);
        ``n_joints``: J, the track's joints."""
        if kind not in PROFILE_POLYNOMIALS:
            raise ConfigError(f"path_profile: expected one of {sorted(PROFILE_POLYNOMIALS)}, found {kind!r}")
        self.kind = kind
        terms = PROFILE_POLYNOMIALS[kind]
        self._powers = np.array([p for p, _ in terms], float)  # (P,)
        self._coefs = np.array([c for _, c in terms], float)  # (P,)
        self.J = int(n_joints)
        self._u2 = np.zeros(1)  # Σ_{k=1}^{L-1} u(k/L)² for L = 0, 1, …: grown on demand
        self.reset()

    def reset(self) -> None:
        """Forget every row."""
        self.starts = np.zeros(0, np.int64)
        """(K,) int64: the rows' start frames, in the order they were added."""
        self._a = np.zeros(0, np.int64)  # anchors: max(start − 1, 0)
        self._upto = np.zeros(0, np.int64)  # interior frames [a + 1, upto) are summed
        # One float row per start, packed: x_a, Σ y_k² and Σ k^p y_k per coordinate (J·3 each, the last P times):
        # one array to add to and select.
        self._rows = np.zeros((0, self._width))

    @property
    def _width(self) -> int:
        return (2 + self._powers.size) * self.J * 3

    def __len__(self) -> int:
        return int(self.starts.shape[0])

    def add(self, track: np.ndarray, start: int) -> None:
        """A new row: the interval beginning at frame ``start`` of ``track`` (T, J, 3), none of its interior frames
        summed yet (its anchor frame ``max(start − 1, 0)`` is read now and must not change)."""
        a = max(int(start) - 1, 0)
        self.starts = np.append(self.starts, int(start))
        self._a = np.append(self._a, a)
        self._upto = np.append(self._upto, a + 1)
        row = np.zeros((1, self._width))
        row[0, : self.J * 3] = np.asarray(track[a], float).reshape(-1)
        self._rows = np.concatenate([self._rows, row])

    def keep(self, rows: np.ndarray) -> None:
        """Keep only the rows selected by ``rows`` (K,) bool (or indices), in their order."""
        self.starts, self._a, self._upto, self._rows = self.starts[rows], self._a[rows], self._upto[rows], self._rows[rows]

    def _parts(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Views of the packed rows: x_a (K, J·3), Σ y_k² (K, J·3), Σ k^p y_k (K, P, J·3)."""
        J3 = self.J * 3
        K = self._rows.shape[0]
        return self._rows[:, :J3], self._rows[:, J3 : 2 * J3], self._rows[:, 2 * J3 :].reshape(K, -1, J3)

    def residuals(self, track: np.ndarray, stop: int) -> tuple[np.ndarray, np.ndarray]:
        """Every row's interval ``[start, stop)`` of ``track`` (T, J, 3) float64, metres: ``sq`` (K, J) m², the
        summed squared distances of its interior frames from the path (NaN for a joint with a NaN coordinate
        there or at the ends), and ``n`` (K,) int64, the interior frames, as
        :func:`~socialaff_sim.model.path.path_residuals` gives them (within the tolerance of docs/design.md §7).
        Frames already summed (before ``stop − 1``, from earlier calls) must not have changed; ``stop`` never
        decreases between calls."""
        e = int(stop) - 1
        self._advance(track, e)
        L = np.maximum(e - self._a, 0)
        n = np.maximum(L - 1, 0)
        K = len(self)
        if not K:
            return np.zeros((0, self.J)), n
        xa, sq0, mom = self._parts()
        # Σ_p c_p L^(−p) Σ_k k^p y_k: the path's fraction-weighted sum of the y_k, (K, J·3)
        w = self._coefs[None] / np.maximum(L, 1).astype(float)[:, None] ** self._powers[None]  # (K, P)
        cross = np.matmul(w[:, None, :], mom)[:, 0]
        D = np.asarray(track[e], float).reshape(1, -1) - xa  # (K, J·3)
        sq = (sq0 - 2.0 * D * cross + D * D * self._u2_of(L)[:, None]).reshape(K, self.J, 3).sum(axis=2)
        # The true sum is ≥ 0: clip the rounding of a near-zero difference (NaN stays NaN).
        return np.maximum(sq, 0.0), n

    def _advance(self, track: np.ndarray, e: int) -> None:
        """Add to each row its interior frames from ``upto`` up to (not including) the end frame ``e``."""
        K = len(self)
        if not K:
            return
        if np.any(self._upto > np.maximum(e, self._a + 1)):
            raise ModelError(f"PathSums.residuals: interior frames past the end frame {e} were summed already (stop went back)")
        lo = int(self._upto.min())
        if lo >= e:
            return
        frames = np.arange(lo, e)
        xa, sq0, mom = self._parts()
        y = np.asarray(track[lo:e], float).reshape(1, e - lo, -1) - xa[:, None]  # (K, F, J·3)
        k = (frames[None] - self._a[:, None]).astype(float)  # (K, F)
        kp = k[:, None, :] ** self._powers[None, :, None]  # (K, P, F)
        # Frames a row must not add: those it summed already, and those before its anchor. Its anchor frame itself
        # adds exactly nothing (y = 0, k = 0; a NaN anchor makes the row NaN either way): the belief's new row, whose
        # first frame here is its anchor, needs no mask.
        if np.any((self._upto > lo) & ~((self._upto == lo + 1) & (self._a == lo))):
            new = frames[None] >= self._upto[:, None]  # (K, F)
            y = np.where(new[:, :, None], y, 0.0)  # a where, not a product: those frames may be NaN
            kp = np.where(new[:, None, :], kp, 0.0)
        sq0 += np.matmul(self._ones(e - lo), y * y)[:, 0]
        mom += np.matmul(kp, y)
        self._upto = np.maximum(self._upto, e)

    @staticmethod
    def _ones(F: int) -> np.ndarray:
        return np.ones((1, F))

    def profile_terms(self, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The profile's powers (P,) and coefficients (P,) and Σ_{k=1}^{L−1} u(k/L)² (n,) for L = 0 … n − 1: what
        :meth:`residuals` reads, for the compiled cuts (:mod:`~.belief_kernel`)."""
        return self._powers.copy(), self._coefs.copy(), self._u2_of(np.arange(int(n))).copy()

    def _u2_of(self, L: np.ndarray) -> np.ndarray:
        """(K,) Σ_{k=1}^{L−1} u(k/L)² of interval lengths ``L`` (K,) (made once per length)."""
        top = int(L.max()) if L.size else 0
        if top >= self._u2.size:
            grown = [float(np.sum(profile(np.arange(1, m) / m, self.kind) ** 2)) if m > 1 else 0.0
                     for m in range(self._u2.size, 2 * top + 1)]
            self._u2 = np.concatenate([self._u2, grown])
        return self._u2[L]
