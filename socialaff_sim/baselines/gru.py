"""``gru``: a small causal recurrent network (PyTorch, CPU) mapping agent 0's history to agent 1's next poses.

Needs the optional extra ``socialaff-sim[neural]`` (torch); without it the package and the method registry
still import, and selecting ``gru`` raises :class:`~socialaff_sim.errors.ConfigError` naming the extra.

Model
    A one-layer GRU reads, frame by frame from t = T0 on, the causal feature rows of
    :mod:`~socialaff_sim.inference.reaction_features` (agent 0's motion since agent 1's last observed frame,
    the gap between the agents, agent 1's own observed velocity, agent 0's velocity; scaled to unit RMS);
    a linear read-out of its state plus a linear skip from the current features give agent 1's whole-skeleton
    displacement from its last observed pose (anchor frame). Both start at zero, so the untrained network is
    ``hold``. Its hidden state carries what it has
    seen of agent 0's track (and, through its own state, its earlier output); it never sees agent 0's later
    frames: under the causal protocol frame t is computed from frames ≤ t, and frames beyond the view
    (a forecast) are rolled on a copy of the state with agent 0 held at its last visible frame.

Training (one class, the training folds only)
    Full-batch Adam on the instance-weighted mean squared displacement error, seeded from the run's
    generator (``torch.manual_seed`` inside a forked torch RNG, so the global torch state is untouched).
    A validation split of the training instances (``validation_fraction``, pair-disjoint where possible)
    picks the hidden size from ``hidden_sizes`` and the epoch (early stopping, ``patience``) by the
    evaluation's metric (mean key-joint distance per instance). If the best network does not beat ``hold``
    on the validation instances, the method falls back to ``hold`` (``hidden_size_ = 0``).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..data.dataset import deal_groups
from ..data.interaction import Interaction
from ..errors import ConfigError, ModelError, NotFittedError
from ..inference.protocol import DEFAULT_N_OBSERVED, Prediction, prediction_from_reactor
from ..inference.reaction_features import N_FEATURES, FeatureConfig, FeatureStream, training_rows
from .ridge import key_columns

try:  # the optional extra socialaff-sim[neural]
    import torch
    from torch import nn
except ImportError:  # pragma: no cover - exercised where torch is absent
    torch = None  # type: ignore[assignment]

__all__ = ["GRUConfig", "GRUReaction", "TORCH_AVAILABLE"]

TORCH_AVAILABLE = torch is not None
"""Whether torch is importable (the ``[neural]`` extra)."""


@dataclass(frozen=True)
class GRUConfig:
    """Settings of ``gru`` (fixed before any evaluation; the validation split chooses among the options)."""

    features: FeatureConfig = field(default_factory=FeatureConfig)
    """[—]: How the input features are computed (the same as ``ridge``'s)."""
    hidden_sizes: tuple[int, ...] = (16, 48)
    """H [units]: hidden sizes the validation split chooses among."""
    max_epochs: int = 400
    """[—]: Full-batch Adam steps at most."""
    patience: int = 40
    """[—]: Stop after this many steps without a better validation error."""
    learning_rate: float = 1e-2
    """[—]: Adam step size."""
    weight_decay: float = 1e-4
    """[—]: Adam weight decay (shrinks the read-out toward ``hold``)."""
    validation_fraction: float = 0.25
    """[—]: Share of the training instances held out for validation."""
    n_observed: int = DEFAULT_N_OBSERVED
    """T0 [frames]: observed frames of agent 1 when the training sequences are built."""

    def __post_init__(self) -> None:
        if not self.hidden_sizes or min(self.hidden_sizes) < 1:
            raise ConfigError(f"hidden_sizes: expected sizes ≥ 1, found {self.hidden_sizes}")
        if self.max_epochs < 1 or self.patience < 1:
            raise ConfigError(f"max_epochs, patience: expected ≥ 1, found {self.max_epochs}, {self.patience}")
        if not 0 < self.validation_fraction < 1:
            raise ConfigError(f"validation_fraction: expected in (0, 1), found {self.validation_fraction}")
        if not self.learning_rate > 0 or self.weight_decay < 0:
            raise ConfigError(f"learning_rate > 0 and weight_decay ≥ 0 expected, found {self.learning_rate}, {self.weight_decay}")


def _require_torch() -> None:
    if torch is None:
        raise ConfigError("method 'gru' needs PyTorch, which is not installed: pip install 'socialaff-sim[neural]'")


if torch is not None:

    class _Net(nn.Module):
        """GRU (N_FEATURES → H), a linear read-out (H → J·3) and a linear skip from the features (N_FEATURES →
        J·3), both zero-initialised: the untrained network is ``hold``, and a linear map of the current
        features (what ``ridge`` fits) is one of the functions it can represent."""

        def __init__(self, hidden: int, n_out: int) -> None:
            super().__init__()
            self.gru = nn.GRU(N_FEATURES, hidden, batch_first=True)
            self.out = nn.Linear(hidden, n_out)
            self.skip = nn.Linear(N_FEATURES, n_out, bias=False)
            for p in (self.out.weight, self.out.bias, self.skip.weight):
                nn.init.zeros_(p)

        def forward(self, x: torch.Tensor, h: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
            y, h = self.gru(x, h)
            return self.out(y) + self.skip(x), h


def _sequences(interactions: Sequence[Interaction], n_observed: int, config: FeatureConfig) -> list[tuple[np.ndarray, np.ndarray]]:
    return [training_rows(inst, n_observed, config)[:2] for inst in interactions if inst.n_frames > n_observed]


def _batch(seqs: Sequence[tuple[np.ndarray, np.ndarray]], scale: np.ndarray, y_scale: float) -> tuple:
    L = max(len(x) for x, _ in seqs)
    X = np.zeros((len(seqs), L, N_FEATURES), dtype=np.float32)
    Y = np.zeros((len(seqs), L, seqs[0][1].shape[1]), dtype=np.float32)
    M = np.zeros((len(seqs), L), dtype=np.float32)
    for i, (x, y) in enumerate(seqs):
        X[i, : len(x)] = x / scale
        Y[i, : len(y)] = y / y_scale
        M[i, : len(x)] = 1.0 / len(x)  # each instance weighs one, as in the metric
    return torch.from_numpy(X), torch.from_numpy(Y), torch.from_numpy(M)


def _key_error(pred: torch.Tensor, Y: torch.Tensor, M: torch.Tensor, kc: np.ndarray, y_scale: float) -> float:
    """Mean over instances of the mean key-joint distance, metres."""
    d = (pred[..., kc] - Y[..., kc]).reshape(*pred.shape[:2], -1, 3).norm(dim=-1).mean(-1) * y_scale
    return float((d * M).sum(1).mean())  # M holds 1 / (frames of the instance) on its frames


class GRUReaction:
    """``gru``: the causal GRU baseline (module docstring). Learned attributes: ``net_`` (or ``None`` for the
    ``hold`` fall-back), ``hidden_size_``, ``epochs_``, ``validation_error_`` / ``validation_hold_error_`` (m),
    ``scale_``, ``y_scale_``."""

    name = "gru"

    def __init__(self, config: GRUConfig | None = None) -> None:
        _require_torch()
        self.config = config or GRUConfig()

    def _train(self, hidden: int, train: tuple, val: tuple, kc: np.ndarray, seed: int) -> tuple[object, float, int]:
        cfg = self.config
        with torch.random.fork_rng(devices=[]):
            torch.manual_seed(seed)
            net = _Net(hidden, train[1].shape[-1])
        opt = torch.optim.Adam(net.parameters(), lr=cfg.learning_rate, weight_decay=cfg.weight_decay)
        best, best_state, best_epoch, since = math.inf, copy.deepcopy(net.state_dict()), 0, 0
        for epoch in range(1, cfg.max_epochs + 1):
            net.train()
            opt.zero_grad()
            pred, _ = net(train[0])
            loss = (((pred - train[1]) ** 2).mean(-1) * train[2]).sum() / train[2].shape[0]
            loss.backward()
            nn.utils.clip_grad_norm_(net.parameters(), 1.0)
            opt.step()
            net.eval()
            with torch.no_grad():
                err = _key_error(net(val[0])[0], val[1], val[2], kc, self.y_scale_)
            if err < best:
                best, best_state, best_epoch, since = err, copy.deepcopy(net.state_dict()), epoch, 0
            else:
                since += 1
                if since >= cfg.patience:
                    break
        net.load_state_dict(best_state)
        net.eval()
        return net, best, best_epoch

    def fit(self, interactions: Sequence[Interaction], *, rng: np.random.Generator) -> GRUReaction:
        """Train on ``interactions`` (one class): validation split, hidden size, early stopping, ``hold`` check."""
        cfg = self.config
        seqs = _sequences(interactions, cfg.n_observed, cfg.features)
        if len(seqs) < 2:
            raise ModelError(f"gru: expected at least 2 training instances longer than T0 = {cfg.n_observed} frames, found {len(seqs)}")
        usable = [i for i in interactions if i.n_frames > cfg.n_observed]
        X = np.concatenate([x for x, _ in seqs])
        Y = np.concatenate([y for _, y in seqs])
        rms = np.sqrt((X**2).mean(0))
        self.scale_ = np.where(rms > 1e-12, rms, 1.0).astype(np.float32)
        self.y_scale_ = float(np.sqrt((Y**2).mean())) or 1.0
        pairs: dict[tuple[str, ...], list[int]] = {}
        for i, inst in enumerate(usable):
            pairs.setdefault(tuple(sorted(inst.actors)), []).append(i)
        groups = pairs if len(pairs) >= 2 else {(str(i),): [i] for i in range(len(usable))}
        k = max(2, round(1 / cfg.validation_fraction))
        folds = [f for f in deal_groups(groups, min(k, len(groups)), rng) if f]
        val_idx = set(folds[0])
        train = _batch([s for i, s in enumerate(seqs) if i not in val_idx], self.scale_, self.y_scale_)
        val = _batch([s for i, s in enumerate(seqs) if i in val_idx], self.scale_, self.y_scale_)
        kc = key_columns(usable[0])
        self.validation_hold_error_ = _key_error(torch.zeros_like(val[1]), val[1], val[2], kc, self.y_scale_)
        seed = int(rng.integers(2**31))
        trained = [(*self._train(hidden, train, val, kc, seed), hidden) for hidden in cfg.hidden_sizes]
        net, err, self.epochs_, hidden = min(trained, key=lambda r: r[1])  # the first of equals: the smaller
        self.validation_error_ = err
        # hold wins ties: the network is used only where it beat hold on the validation instances
        self.net_, self.hidden_size_ = (net, hidden) if err < self.validation_hold_error_ else (None, 0)
        self.n_out_ = Y.shape[1]
        return self

    def _check(self) -> None:
        if not hasattr(self, "n_out_"):
            raise NotFittedError("method 'gru': call fit(interactions, rng=...) before start or predict")

    def start(self, *, n_observed: int, offline: bool, rng: np.random.Generator) -> GRUReactor:
        """A reactor for one instance (the same under every protocol: it uses only what each view holds)."""
        self._check()
        return GRUReactor(self, n_observed)

    def predict(self, interaction: Interaction, *, n_observed: int, rng: np.random.Generator) -> Prediction:
        """Agent 1's whole track from one view of the whole instance (agent 1 after ``n_observed`` unused)."""
        view = interaction.hide_agent_after(1, n_observed).replace(subevents=None)
        return prediction_from_reactor(self.start(n_observed=n_observed, offline=True, rng=rng), view,
                                       n_observed=n_observed)

    def _run(self, rows: np.ndarray, h: object) -> tuple[np.ndarray, object]:
        """Displacements (F, J·3), metres, for feature rows (F, N_FEATURES), and the state after them."""
        if self.net_ is None or len(rows) == 0:
            return np.zeros((len(rows), self.n_out_)), h
        x = torch.from_numpy((rows / self.scale_).astype(np.float32))[None]
        with torch.no_grad():
            y, h = self.net_(x, h)  # type: ignore[operator]
        return y[0].double().numpy() * self.y_scale_, h


class GRUReactor:
    """``gru`` on one instance: the hidden state advances over frames whose agent-0 frame is visible; frames
    beyond the view are rolled on a copy of the state."""

    def __init__(self, method: GRUReaction, n_observed: int) -> None:
        self.method = method
        self.stream = FeatureStream(n_observed, method.config.features)
        self._h: object = None
        self._next = n_observed  # first frame not yet committed to the state
        self._out: dict[int, np.ndarray] = {}  # committed outputs not yet returned

    def react(self, view: Interaction, start: int, stop: int) -> Prediction:
        """Agent 1's frames [start, stop) from ``view``."""
        visible = view.n_frames
        if self._next < visible:
            rows = self.stream.rows(view, self._next, visible)
            y, self._h = self.method._run(rows, self._h)
            self._out.update(zip(range(self._next, visible), y))
            self._next = visible
        parts = [self._out.pop(t) for t in range(start, min(stop, visible))]
        self._out = {t: v for t, v in self._out.items() if t >= stop}
        if stop > visible:
            rows = self.stream.rows(view, max(start, visible), stop)
            y, _ = self.method._run(rows, self._h)
            parts.extend(y)
        joints = self.stream.anchor.to_world(np.stack(parts))
        return Prediction(joints=joints, key_joints=view.layout.key_joints(joints), subevents=None, n_observed=0)
