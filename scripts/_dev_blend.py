"""The switching regression's blend over several trace sets, for scripts/dev_switching.py ``--v2`` (issue 24).

:func:`blend_sources` is ``SwitchingRegression.fit`` with each family reading its own trace set (``SOURCES``:
the family ``plan_v2`` reads V2's traces, every other family the default model's); it reproduces
``SwitchingRegression`` exactly when every family reads one trace set (dev_switching.py checks that on every
class). :func:`blend_displacement` predicts with the fitted blend. Only scripts/dev_switching.py imports this module.
"""

from __future__ import annotations

import numpy as np

from socialaff_sim.data import Interaction
from socialaff_sim.inference.reaction_regression import (
    HOLD, blend_weights, cv_errors, fold_predictions, inner_folds, key_columns, ridge_solve, select, stack_instances,
)
from socialaff_sim.inference.switching import (
    FAMILIES, PRIORS, SwitchingConfig, Trace, instance_rows, switching_columns, switching_scale,
)

V2_FAMILY = ("plan_v2", FAMILIES[1][1])  # the plan's candidates, read from V2's traces
SOURCES = {"plan_v2": "v2"}  # family -> trace set (every other family: "own", the default model's)


def _prior_of(groups: tuple[str, ...]) -> str | None:
    return next((g for g in groups if g in PRIORS), None)


BlendMember = tuple[str, tuple[str, ...], float, float, np.ndarray, np.ndarray]
"""(family, groups, λ, α, columns (F_m,) int64, coefficients (F_m, J·3)) of one member of the blend."""
Rows = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""``instance_rows``' (rows (N, ·), targets (N, J·3) m, ``from_plan`` prior (N, J·3) m, ``from_primitive`` prior)."""


def blend_sources(
    train: list[Interaction], sources: dict[str, list[Trace]], n_sub: dict[str, int], cfg: SwitchingConfig,
    rng: np.random.Generator,
) -> tuple[list[BlendMember], dict[str, np.ndarray]]:
    """``SwitchingRegression.fit`` with each family reading its own trace set (``SOURCES``: family → set name, else
    ``"own"``; ``sources``: set name → one trace per instance of ``train``; ``n_sub``: S per set). Without the
    library's single-instance fallback (every class here has at least two inner folds).

    Returns the members with α > 0 and each set's column scales (F,)."""
    stacked: dict[str, tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]] = {}
    scale: dict[str, np.ndarray] = {}
    for src, traces in sources.items():
        (X, Y, pp, prp), w, ids = stack_instances(
            train, cfg.n_observed, lambda i, inst, tr=traces: instance_rows(inst, tr[i], cfg.n_observed, cfg.features), src)
        scale[src] = switching_scale(X, w, n_sub[src])
        stacked[src] = (X / scale[src], Y, {"from_plan": pp, "from_primitive": prp})
    folds = inner_folds(train, np.unique(ids), cfg.inner_folds, rng, contiguous=cfg.contiguous)
    kc = key_columns(train[0])
    Y = stacked["own"][1]
    Yk = Y[:, kc]
    winners, preds = [], []
    for family, _ in cfg.families:
        src = SOURCES.get(family, "own")
        Xs, _, priors = stacked[src]
        candidates = {g: switching_columns(g, n_sub[src]) for g in cfg.candidates(family)}
        cv: dict[tuple[tuple[str, ...], float], float] = {}
        for prior in (None,) + PRIORS:
            some = {g: c for g, c in candidates.items() if _prior_of(g) == prior}
            if some:
                cv.update(cv_errors(Xs, Yk, w, ids, folds, some, cfg.penalties,
                                    offset=priors[prior][:, kc] if prior else None, from_offset=some if prior else ()))
        groups, lam = select({k: v for k, v in cv.items() if k[0] != HOLD})
        winners.append((family, groups, lam))
        prior = _prior_of(groups)
        base = priors[prior][:, kc] if prior else np.zeros_like(Yk)
        preds.append(fold_predictions(Xs, Yk, w, ids, folds, candidates[groups], lam, base))
    alpha, _ = blend_weights(np.stack(preds), Yk, ids, cfg.blend_steps)
    wn = w / w.sum()
    members: list[BlendMember] = []
    for (family, groups, lam), a in zip(winners, alpha, strict=True):
        if a <= 0:
            continue
        src = SOURCES.get(family, "own")
        Xs, _, priors = stacked[src]
        cols = switching_columns(groups, n_sub[src])
        prior = _prior_of(groups)
        target = Y - priors[prior] if prior else Y
        if len(cols) and np.isfinite(lam):
            Xc = Xs[:, cols]
            coef = ridge_solve((Xc * wn[:, None]).T @ Xc, (Xc * wn[:, None]).T @ target, lam)
        else:
            cols, coef = np.zeros(0, np.int64), np.zeros((0, Y.shape[1]))
        members.append((family, groups, lam, float(a), cols, coef))
    return members, scale


def blend_displacement(members: list[BlendMember], scale: dict[str, np.ndarray], rows: dict[str, Rows]) -> np.ndarray:
    """(N, J·3) anchor-frame displacements, metres: the blend's, from each trace set's rows of one validation instance."""
    out = np.zeros_like(rows["own"][1])
    for family, groups, _, a, cols, coef in members:
        X, _, pp, prp = rows[SOURCES.get(family, "own")]
        prior = _prior_of(groups)
        part = (pp if prior == "from_plan" else prp if prior == "from_primitive" else np.zeros_like(out)).copy()
        if len(cols):
            part += (X[:, cols] / scale[SOURCES.get(family, "own")][cols]) @ coef
        out += a * part
    return out
