"""Type-level merge-and-split moves on the initial parses (our addition to Algorithm 1's start).

Hard-EM (:mod:`~socialaff_sim.learning.initial`) and the paper's Metropolis-Hastings moves change
one instance's parse at a time, so they cannot fix a mistake every instance shares: the equal-part
start cuts a long first sub-event (a walk-in that takes half the instance) into two types and
lumps two short ones (raise and strike) into one, and no single-instance move can undo that
without first making that instance disagree with all the others. A type-level move does it for
all instances at once, in the spirit of split-merge samplers for mixtures:

* merge every interval of type b into its preceding neighbour (the following one where b comes
  first), which frees label b;
* split every interval of another type c at the atom boundary nearest its middle, the second
  half taking label b;
* refine the result by hard-EM and score it by log P*.

Each pass screens every admissible (b, c) after one hard-EM round (``LearningConfig.init_type_screen_rounds``; 0: as
the move leaves it), refines the three best further,
and keeps the best if it beats the current log P*; the search stops when a pass finds no improvement or after ``LearningConfig.init_type_passes``.
It is a deterministic coordinate ascent on the same objective, before the chain starts.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from .parse import Parse, ParseSpace

__all__ = ["merge_split", "restructure"]


def merge_split(parse: Parse, space: ParseSpace, b: int, c: int) -> Parse | None:
    """Merge type ``b``'s interval into its preceding neighbour (its following one when it comes
    first), then split type ``c``'s interval at the atom boundary nearest its middle, the second half
    labelled ``b``; None when the instance is all ``b`` or the result breaks the label constraints."""
    merged: list[tuple[int, int, int]] = []
    pending: int | None = None  # start atom of a leading b, waiting for its following neighbour
    for x0, x1, s in parse.atom_spans(space.n_atoms):
        if s == b:
            if merged:
                merged[-1] = (merged[-1][0], x1, merged[-1][2])
            else:
                pending = x0
        elif pending is not None:
            merged.append((pending, x1, s))
            pending = None
        else:
            merged.append((x0, x1, s))
    if not merged:
        return None
    out: list[tuple[int, int, int]] = []
    for x0, x1, s in merged:
        if s == c and x1 - x0 >= 2:
            mid = 0.5 * (space.bounds[x0] + space.bounds[x1])
            inner = np.arange(x0 + 1, x1)
            m = int(inner[np.argmin(np.abs(space.bounds[inner] - mid))])
            out += [(x0, m, c), (m, x1, b)]
        else:
            out.append((x0, x1, s))
    new = Parse(tuple(x for x, _, _ in out), tuple(s for _, _, s in out))
    return new if space.is_valid(new) else None


def restructure(
    spaces: Sequence[ParseSpace],
    parses: Sequence[Parse],
    n_labels: int,
    *,
    refine: Callable[[list[Parse], int], list[Parse]],
    score: Callable[[list[Parse]], float],
    passes: int,
    rounds: int,
    keep: int = 3,
    screen_rounds: int = 1,
) -> tuple[list[Parse], float]:
    """Best parses found by type-level merge-and-split passes (see the module doc) and their score.

    ``refine(parses, rounds)`` improves a set of parses by that many hard-EM rounds (0: unchanged); ``score``
    gives log P* of a set.
    Each pass screens every admissible move after ``screen_rounds`` refining rounds and refines the ``keep``
    best of them for the rest of ``rounds`` (``rounds − screen_rounds``, at least 0).
    """
    current = list(parses)
    best = score(current)
    S = n_labels
    for _ in range(passes):
        screened: list[tuple[float, list[Parse]]] = []
        for b in range(S):
            for c in range(S):
                if b == c:
                    continue
                cand = [merge_split(p, sp, b, c) for p, sp in zip(current, spaces, strict=True)]
                if any(p is None for p in cand):
                    continue
                once = refine([p for p in cand if p is not None], screen_rounds)
                screened.append((score(once), once))
        screened.sort(key=lambda item: -item[0])
        found: tuple[float, list[Parse]] | None = None
        for _, once in screened[:keep]:
            refined = refine(once, max(rounds - screen_rounds, 0))
            value = score(refined)
            if found is None or value > found[0]:
                found = (value, refined)
        if found is None or not found[0] > best:
            break
        best, current = found
    return current, best
