"""Metropolis-Hastings over parses with the merge, split and relabel dynamics (Algorithm 1, outer loop).

The kernel is generic: it needs only a :class:`ParseTarget`, which returns the log target
probability of the state in which one instance's parse is replaced. The proposals (our
reading of the paper's λ-dynamics, which it names but does not spell out):

* **split** (probability ``p_split``): choose an atomic boundary b that is not a parse
  boundary with probability ∝ exp(λ d_b), then a label pair (left, right) for the two new
  intervals uniformly among the pairs the constraints allow;
* **merge** (``p_merge``): choose a parse boundary b with probability ∝ exp(−λ d_b), then a
  label for the merged interval uniformly among those allowed;
* **relabel** (``p_relabel``): choose an interval uniformly, then a different label uniformly
  among those that give a valid parse, where a label already used as often as the constraint
  allows (``max_repeats``, e.g. the default's one interval per type) is *swapped* with the
  interval holding it instead of being refused (with no such constraint, as in the paper, no
  swap ever happens);
* **shift** (our addition, drawn first with probability ``p_shift``; the three above share the
  rest in the paper's proportions): choose a parse boundary with probability ∝ exp(−λ d_b) and
  move it to a neighbouring atomic boundary inside its two intervals with probability
  ∝ exp(λ d_b′), labels kept — a merge immediately followed by a split.

d_b ∈ [0, 1] is the normalized motion change at b, so splits prefer boundaries where the
motion changes and merges prefer those where it does not. A move with no admissible choice
leaves the state unchanged (counted as proposed and rejected). :func:`mh_step` can temper the
target: at temperature T it accepts with min(1, exp((log P*′ − log P*) / T) q_rev / q_fwd), so the
chain's stationary distribution is ∝ P*^(1/T). The acceptance ratio uses the exact
reverse-move probability: a split's reverse is the merge at the same boundary back to the
old label, a merge's reverse the split back to the two old labels, a relabel's reverse the
relabel back, a shift's reverse the shift back, each with its own count of choices and its own
normalization of the λ-weights in the new state.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple, Protocol

import numpy as np

from .config import LearningConfig
from .parse import Parse, ParseSpace

__all__ = ["MOVES", "ParseTarget", "FunctionTarget", "Proposal", "StepResult", "draw_move", "propose", "propose_move", "mh_step"]

MOVES: tuple[str, ...] = ("merge", "split", "relabel", "shift")
"""Names of the dynamics."""


class ParseTarget(Protocol):
    """Log target over the parses of all instances, re-scored one instance at a time."""

    def propose(self, i: int, parse: Parse) -> float:
        """Log target of the current state with instance ``i``'s parse replaced by ``parse``."""
        ...

    def accept(self) -> None:
        """Make the last proposed state current."""
        ...

    def reject(self) -> None:
        """Discard the last proposed state."""
        ...


class FunctionTarget:
    """A :class:`ParseTarget` from a plain function of all parses (for tests and small problems)."""

    def __init__(self, fn: Callable[[list[Parse]], float], parses: list[Parse]) -> None:
        self.fn = fn
        self.parses = list(parses)
        self._pending: tuple[int, Parse] | None = None

    def propose(self, i: int, parse: Parse) -> float:
        trial = list(self.parses)
        trial[i] = parse
        self._pending = (i, parse)
        return float(self.fn(trial))

    def accept(self) -> None:
        if self._pending is not None:
            i, p = self._pending
            self.parses[i] = p
        self._pending = None

    def reject(self) -> None:
        self._pending = None


@dataclass(frozen=True)
class Proposal:
    """A proposed parse with the log probabilities of the move and of its reverse."""

    parse: Parse
    move: str
    log_q_forward: float
    log_q_reverse: float


def _q(cfg: LearningConfig, p: float) -> float:
    """Probability of one of the paper's dynamics when a shift is drawn first with ``p_shift``."""
    return (1.0 - cfg.p_shift) * p


def _log_choice(weights: np.ndarray, idx: int) -> float:
    return float(np.log(weights[idx]) - np.log(weights.sum()))


def _split(space: ParseSpace, p: Parse, cfg: LearningConfig, rng: np.random.Generator) -> Proposal | None:
    A = space.n_atoms
    free = np.setdiff1d(np.arange(1, A), np.asarray(p.starts))
    if free.size == 0:
        return None
    w = np.exp(cfg.lam * space.change[free])
    c = int(rng.choice(free.size, p=w / w.sum()))
    b = int(free[c])
    k = int(np.searchsorted(p.starts, b) - 1)  # the interval containing b
    ok = space.pair_options(p.labels, k)
    n_ok = int(ok.sum())
    if n_ok == 0:
        return None
    l1, l2 = np.argwhere(ok)[int(rng.integers(n_ok))]
    new = Parse(p.starts[: k + 1] + (b,) + p.starts[k + 1 :], p.labels[:k] + (int(l1), int(l2)) + p.labels[k + 1 :])
    log_f = np.log(_q(cfg, cfg.p_split)) + _log_choice(w, c) - np.log(n_ok)
    # Reverse: merge at b (parse boundary k + 1 of the new parse) back to the old label.
    pb = np.asarray(new.starts[1:])
    wm = np.exp(-cfg.lam * space.change[pb])
    n_rev = int(space.single_options(new.labels, k, k + 2).sum())
    log_r = np.log(_q(cfg, cfg.p_merge)) + _log_choice(wm, k) - np.log(n_rev)
    return Proposal(new, "split", float(log_f), float(log_r))


def _merge(space: ParseSpace, p: Parse, cfg: LearningConfig, rng: np.random.Generator) -> Proposal | None:
    if p.n_intervals < 2:
        return None
    pb = np.asarray(p.starts[1:])
    w = np.exp(-cfg.lam * space.change[pb])
    c = int(rng.choice(pb.size, p=w / w.sum()))
    b = int(pb[c])
    k = c  # intervals k and k + 1 merge
    ok = space.single_options(p.labels, k, k + 2)
    n_ok = int(ok.sum())
    if n_ok == 0:
        return None
    s = int(np.flatnonzero(ok)[int(rng.integers(n_ok))])
    new = Parse(p.starts[: k + 1] + p.starts[k + 2 :], p.labels[:k] + (s,) + p.labels[k + 2 :])
    log_f = np.log(_q(cfg, cfg.p_merge)) + _log_choice(w, c) - np.log(n_ok)
    free = np.setdiff1d(np.arange(1, space.n_atoms), np.asarray(new.starts))
    ws = np.exp(cfg.lam * space.change[free])
    n_rev = int(space.pair_options(new.labels, k).sum())
    log_r = np.log(_q(cfg, cfg.p_split)) + _log_choice(ws, int(np.flatnonzero(free == b)[0])) - np.log(n_rev)
    return Proposal(new, "merge", float(log_f), float(log_r))


def _relabelled(space: ParseSpace, labels: tuple[int, ...], k: int, s: int) -> tuple[int, ...]:
    """The labels with interval ``k`` relabelled ``s``; when ``s`` is already used ``max_repeats`` times
    elsewhere, the (first) other interval holding it takes interval ``k``'s old label (a swap)."""
    new = list(labels)
    old = new[k]
    new[k] = s
    if space.max_repeats is not None and sum(1 for i, x in enumerate(labels) if x == s and i != k) >= space.max_repeats:
        new[next(i for i, x in enumerate(labels) if x == s and i != k)] = old
    return tuple(new)


def _relabel_options(space: ParseSpace, p: Parse, k: int) -> list[Parse]:
    """The valid parses a relabel of interval ``k`` can reach (one per new label, in label order)."""
    out = []
    for s in range(space.n_labels):
        if s == p.labels[k]:
            continue
        q = Parse(p.starts, _relabelled(space, p.labels, k, s))
        if space.is_valid(q):
            out.append(q)
    return out


def _relabel(space: ParseSpace, p: Parse, cfg: LearningConfig, rng: np.random.Generator) -> Proposal | None:
    K = p.n_intervals
    k = int(rng.integers(K))
    options = _relabel_options(space, p, k)
    if not options:
        return None
    new = options[int(rng.integers(len(options)))]
    log_f = np.log(_q(cfg, cfg.p_relabel)) + _log_relabel_choice(space, p, new)
    log_r = np.log(_q(cfg, cfg.p_relabel)) + _log_relabel_choice(space, new, p)
    return Proposal(new, "relabel", float(log_f), float(log_r))


def _log_relabel_choice(space: ParseSpace, p: Parse, new: Parse) -> float:
    """log of the probability that a relabel from ``p`` gives ``new``: a swap of two labels is reached by
    relabelling either of its intervals, so the probabilities of every interval that reaches it add up."""
    K = p.n_intervals
    total = 0.0
    for k in np.flatnonzero(np.asarray(p.labels) != np.asarray(new.labels)):
        options = _relabel_options(space, p, int(k))
        if new in options:
            total += 1.0 / (K * len(options))
    return float(np.log(total))


def _shift_candidates(space: ParseSpace, starts: tuple[int, ...], k: int) -> np.ndarray:
    """Atom boundaries next to parse boundary ``starts[k + 1]`` inside intervals k and k + 1."""
    b = starts[k + 1]
    lo = starts[k]
    hi = starts[k + 2] if k + 2 < len(starts) else space.n_atoms
    cand = np.array([b - 1, b + 1])
    return cand[(cand > lo) & (cand < hi)]


def _shift(space: ParseSpace, p: Parse, cfg: LearningConfig, rng: np.random.Generator) -> Proposal | None:
    if p.n_intervals < 2:
        return None
    pb = np.asarray(p.starts[1:])
    w = np.exp(-cfg.lam * space.change[pb])
    k = int(rng.choice(pb.size, p=w / w.sum()))
    cand = _shift_candidates(space, p.starts, k)
    if cand.size == 0:
        return None
    ws = np.exp(cfg.lam * space.change[cand])
    c2 = int(rng.choice(cand.size, p=ws / ws.sum()))
    new = Parse(p.starts[: k + 1] + (int(cand[c2]),) + p.starts[k + 2 :], p.labels)
    log_f = np.log(cfg.p_shift) + _log_choice(w, k) + _log_choice(ws, c2)
    pb2 = np.asarray(new.starts[1:])
    w2 = np.exp(-cfg.lam * space.change[pb2])
    cand2 = _shift_candidates(space, new.starts, k)
    ws2 = np.exp(cfg.lam * space.change[cand2])
    log_r = np.log(cfg.p_shift) + _log_choice(w2, k) + _log_choice(ws2, int(np.flatnonzero(cand2 == p.starts[k + 1])[0]))
    return Proposal(new, "shift", float(log_f), float(log_r))


_MOVE_FUNCTIONS = {"merge": _merge, "split": _split, "relabel": _relabel, "shift": _shift}


def draw_move(cfg: LearningConfig, rng: np.random.Generator) -> str:
    """Which dynamics to try: "shift" with ``p_shift``, else merge / split / relabel in their proportions."""
    if cfg.p_shift > 0 and rng.random() < cfg.p_shift:
        return "shift"
    u = rng.random()
    if u < cfg.p_merge:
        return "merge"
    if u < cfg.p_merge + cfg.p_split:
        return "split"
    return "relabel"


def propose_move(
    space: ParseSpace, parse: Parse, cfg: LearningConfig, rng: np.random.Generator, move: str
) -> Proposal | None:
    """One proposal of the dynamics ``move``; ``None`` when it has no admissible choice."""
    return _MOVE_FUNCTIONS[move](space, parse, cfg, rng)


def propose(space: ParseSpace, parse: Parse, cfg: LearningConfig, rng: np.random.Generator) -> Proposal | None:
    """Draw one move; ``None`` when the drawn dynamics has no admissible choice."""
    return propose_move(space, parse, cfg, rng, draw_move(cfg, rng))


class StepResult(NamedTuple):
    """Outcome of one Metropolis-Hastings step."""

    parse: Parse
    log_p: float
    accepted: bool
    move: str
    """The dynamics drawn (one of :data:`MOVES`), also when it had no admissible choice (then rejected)."""


def mh_step(
    space: ParseSpace,
    i: int,
    parse: Parse,
    current_log_p: float,
    target: ParseTarget,
    cfg: LearningConfig,
    rng: np.random.Generator,
    temperature: float = 1.0,
) -> StepResult:
    """One Metropolis-Hastings step on instance ``i`` from ``parse`` with log target ``current_log_p``,
    leaving the target raised to the power 1 / ``temperature`` invariant."""
    move = draw_move(cfg, rng)
    prop = propose_move(space, parse, cfg, rng, move)
    if prop is None:
        return StepResult(parse, current_log_p, False, move)
    new_log_p = target.propose(i, prop.parse)
    log_a = (new_log_p - current_log_p) / temperature + prop.log_q_reverse - prop.log_q_forward
    if np.isfinite(new_log_p) and np.log(rng.random()) < log_a:
        target.accept()
        return StepResult(prop.parse, new_log_p, True, prop.move)
    target.reject()
    return StepResult(parse, current_log_p, False, prop.move)
