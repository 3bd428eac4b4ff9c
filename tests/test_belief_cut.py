"""The forward belief's cut after session 26's cuts (issue 24), against the cut it replaces written out here (commit
323edde), bitwise: the posterior and the belief at every frame of a stream longer than several horizons (the long
bucket), with the model's absent joint NaN, with labels unique or not, a minimum sub-event length (short intervals −inf), a type
whose duration is undefined (its rows all −inf), a frame where every row is −inf (nothing possible), after a reset at
a later origin, and on the tables of a refitted model. The cuts: F's per-label copy as one flat copy, the closed
intervals' duration term and their shortness from per-model tables of d frames, the densities by
:class:`~socialaff_sim.inference.row_density.RowSet`, one ``np.errstate`` per cut, np.append and np.max by the calls they
make."""

from __future__ import annotations


import numpy as np
import pytest

from conftest import belief_track, model_with
from socialaff_sim.inference.forward_belief import ForwardBelief


def _logsumexp_finite(x: np.ndarray, axis: int) -> np.ndarray:
    """forward_belief._logsumexp_finite as the replaced cut called it (323edde), written out."""
    top = np.maximum.reduce(x, axis=axis, keepdims=True)
    safe = np.where(np.isfinite(top), top, 0.0)
    with np.errstate(divide="ignore"):
        out = np.log(np.add.reduce(np.exp(x - safe), axis=axis)) + np.squeeze(safe, axis=axis)
    return out


def _masks(bits: np.ndarray, M: int) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Per target label s the source masks without s and the masks they become (what ForwardBelief kept as _src and
    _dst until its recursion read only their flat indices), from the label bits."""
    masks = np.arange(M)
    if M > 1:
        src = [masks[(masks & bit) == 0] for bit in bits]
        return src, [m | bit for m, bit in zip(src, bits)]
    return [masks] * len(bits), [masks] * len(bits)


class _Replaced(ForwardBelief):
    """ForwardBelief with _cut's recursion and _closing as they were (323edde)."""

    def _cut(self, track: np.ndarray, b: int) -> None:
        S, M = self.S, self.M
        if b == self.origin:
            F = np.full((M, S), -np.inf)
            prior = self.model.log_start_probs_ if b == 0 else np.full(S, -np.log(S))
            if M > 1:
                F[self._bits, np.arange(S)] = prior
            else:
                F[0] = prior
        else:
            C = np.full((M, S), -np.inf)
            has_long = self._has_long
            starts = np.append(self._starts, b - self.horizon) if has_long else self._starts
            if starts.size:
                seg = self._closing(track, starts, b)
                C = _logsumexp_finite(self._F + seg[: self._starts.size, None, :], axis=0)
                if has_long:
                    C = np.logaddexp(C, self._long + seg[-1][None])
            V = _logsumexp_finite(C[:, :, None] + self._trans[None], axis=1)
            F = np.full((M, S), -np.inf)
            src, dst = _masks(self._bits, M)
            for s in range(S):
                F[dst[s], s] = V[src[s], s]
        self._starts = np.append(self._starts, b)
        self._F = np.concatenate([self._F, F[None]])
        if self._sums is not None:
            self._sums.add(track, b)
        old = self._starts <= b - self.horizon
        if old.any():
            self._long = np.logaddexp(self._long, _logsumexp_finite(self._F[old], axis=0))
            self._starts, self._F = self._starts[~old], self._F[~old]
            if self._sums is not None:
                self._sums.keep(~old)
            if self.M > 1:
                merged = _logsumexp_finite(self._long, axis=0)
                self._long = np.full((self.M, self.S), -np.inf)
                self._long[self._bits, np.arange(self.S)] = merged
        top = max(float(np.max(self._F)), float(np.max(self._long)))
        if np.isfinite(top):
            self._F -= top
            self._long -= top
        self._G = _logsumexp_finite(self._F, axis=1)
        self._G_long = _logsumexp_finite(self._long, axis=0)
        self._has_long = bool(np.isfinite(self._long).any())
        if self._has_long:
            self._long_read = self._G_long + self._surv[self.horizon]
        self._posterior = None
        self.cuts += 1

    def _closing(self, track: np.ndarray, starts: np.ndarray, b: int) -> np.ndarray:
        model = self.model
        stops = np.full(starts.size, b)
        feats = self._features(track, starts, b)
        short = (stops - starts) < model.config.min_subevent_seconds * self.fps
        tab = self._tables
        out = tab.spatial(feats.end[:1]) + tab.motion(feats.disp) + tab.duration(feats.seconds)
        if self._sums is None:
            for s in range(self.S):
                out[:, s] += model.log_path(s, feats)
        else:
            nf = feats.path_n.astype(float)[:, None, None]
            ll = -1.5 * nf * self._path_c[None] - feats.path_sq[:, None, :] / self._path_2s2[None]
            out += np.where(self._path_use[None], ll, 0.0).sum(axis=2)
        out[short] = -np.inf
        return out



def _both(model, rng: np.random.Generator, T: int, stride: int, horizon: int, resets: tuple[int, ...] = ()) -> None:  # noqa: ANN001
    track = belief_track(rng, T)
    new, old = (cls(model, 30.0, stride=stride, horizon=horizon) for cls in (ForwardBelief, _Replaced))
    seen_long = seen_none = False
    for t in range(1, T):
        if t in resets:
            new.reset(t - 3)
            old.reset(t - 3)
        new.advance(track, t)
        old.advance(track, t)
        a, b = new.posterior(t), old.posterior(t)
        assert a[0].tobytes() == b[0].tobytes() and a[1].tobytes() == b[1].tobytes(), t
        assert new.belief(t).tobytes() == old.belief(t).tobytes()
        assert new._F.tobytes() == old._F.tobytes() and new._long.tobytes() == old._long.tobytes()
        seen_long |= new._has_long
        seen_none |= not np.isfinite(new._F).any()
    assert seen_long  # the long bucket was used
    return seen_none


@pytest.mark.parametrize("unique", [True, False])
@pytest.mark.parametrize(("stride", "horizon"), [(6, 60), (1, 9), (4, 30)])
def test_cut_is_the_replaced_cuts(shake8_model, rng: np.random.Generator, unique: bool, stride: int, horizon: int) -> None:  # noqa: ANN001
    _both(model_with(shake8_model, unique_labels=unique), rng, 260, stride, horizon, resets=(150,))


def test_short_intervals_and_a_type_without_duration(shake8_model, rng: np.random.Generator) -> None:  # noqa: ANN001
    model = model_with(shake8_model, min_subevent_seconds=0.5)
    model.duration_params_ = np.array(model.duration_params_, float)
    model.duration_params_[1] = np.nan  # that type's intervals: −inf
    _both(model, rng, 200, 3, 36)


def test_nothing_possible(shake8_model, rng: np.random.Generator) -> None:  # noqa: ANN001
    """Every interval too short for the horizon: every row −inf at some cut (uniform posterior), as before."""
    model = model_with(shake8_model, min_subevent_seconds=5.0)
    assert _both(model, rng, 120, 6, 30)


def test_a_refit_reads_new_tables(shake8_model, rng: np.random.Generator) -> None:  # noqa: ANN001
    model = model_with(shake8_model)
    _both(model, rng, 90, 6, 30)
    first = ForwardBelief(model, 30.0, stride=6, horizon=30)._dur
    model.duration_params_ = np.array(model.duration_params_, float) * 1.1  # a refit's new parameters
    fb = ForwardBelief(model, 30.0, stride=6, horizon=30)
    assert fb._dur is not first and not np.array_equal(fb._dur, first)
    _both(model, rng, 90, 6, 30)


def test_one_plans_path_is_np_sums() -> None:
    """_replan's path of one plan (branches = 1) is 0.0 + that plan's weighted path instead of np.sum over the
    one-element list: the same bits, NaN (an absent joint), −0.0 (np.sum's reduction starts from 0: the path itself
    would keep −0.0) and huge values included."""
    rng = np.random.default_rng(3)
    for F in (1, 2, 5):
        path = rng.normal(size=(F, 5, 3)) * np.exp(rng.normal(scale=20, size=(F, 5, 3)))
        path[0, 1] = np.nan
        path[-1, 2, 0] = -0.0
        for w in (1.0, 0.37):
            paths = [w * path]
            assert (paths[0] + 0.0).tobytes() == np.sum(paths, axis=0).tobytes()
            assert paths[0].tobytes() != np.sum(paths, axis=0).tobytes()  # the −0.0: the path alone would differ
