"""What the environment asks of the affordance model, behind one small protocol.

The environment needs three model-dependent things: a proposal of agent 1's key
joints for the next frame (the base of ``residual`` actions), the current
sub-event belief (part of the observation) and the affordance log-likelihood of
the robot's key joints (a reward term). An :class:`AffordanceAdapter` provides
them. Two adapters ship:

* :class:`GroundTruthAdapter` (no model needed): the proposal is agent 1's
  recorded key joints, the belief a one-hot of the recorded sub-event (zeros
  on unlabelled frames), and the "log-likelihood" a documented proxy, not the
  affordance model: an isotropic Gaussian of standard deviation σ of the robot's
  key frames around the recording retargeted onto the robot (the proposal the
  robot was given for that frame). It is an oracle (it reads agent 1's
  recording) and the reference every model is compared with.
* :class:`~socialaff_sim.environment.model_adapter.ModelAdapter`: a fitted
  :class:`~socialaff_sim.learning.SocialAffordanceModel` scores the
  robot under the current sub-event's spatial potentials, and the online
  synthesizer provides the proposal and the belief.

Coordinates: proposals are in the instance's own data frame (the frame of
``Interaction.joints``, metres, z up); the environment retargets them. A
:class:`RobotPose` gives an adapter the robot's key frames both in the robot
frame and mapped back onto agent 1's body in the data frame
(:class:`~socialaff_sim.environment.bodymap.RobotToAgent`, computed on demand).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple, Protocol, runtime_checkable

import numpy as np

from ..data.interaction import Interaction
from ..data.skeletons import N_KEY
from ..errors import ConfigError, SimulationError
from ..retarget.intent import NO_INTENT, TouchIntent

__all__ = ["AdapterFrame", "AffordanceScore", "RobotPose", "AffordanceAdapter", "GroundTruthAdapter"]


class AdapterFrame(NamedTuple):
    """What an adapter says about one frame."""

    proposal: np.ndarray
    """(5, 3) float64, metres, data frame: agent 1's proposed key joints (NaN where unknown)."""
    belief: np.ndarray
    """(S,) float64: probability of each sub-event of :meth:`AffordanceAdapter.subevent_names` (zeros: unknown)."""
    subevent: int
    """Index of the current sub-event in the adapter's names, −1 when unknown."""
    subevent_name: str | None
    """Its name, ``None`` when unknown."""
    intent: TouchIntent = NO_INTENT
    """The model's intent to touch at this frame (:class:`~socialaff_sim.retarget.intent.TouchIntent`), passed to
    the simulator's retargeting as ``socialaff-sim simulate`` passes it; :data:`NO_INTENT` for the recording."""


class AffordanceScore(NamedTuple):
    """An affordance log-likelihood together with what is needed to normalise it."""

    log_likelihood: float
    """log φ of the configuration (−inf allowed)."""
    upper_bound: float
    """An upper bound of log φ over configurations, same sub-event (so log φ − bound ≤ 0)."""
    n_terms: int
    """Number of joint factors summed in log φ (0: nothing to score)."""


class RobotPose:
    """The robot's key frames after a step, in the forms an adapter may score."""

    def __init__(self, t: int, robot_keys: np.ndarray, reference: np.ndarray, obj: np.ndarray | None,
                 to_agent: Callable[[], np.ndarray]) -> None:
        self.t = t
        """The data frame reached."""
        self.robot_keys = robot_keys
        """(5, 3) float64, metres, robot frame: the robot's key frames in physics."""
        self.reference = reference
        """(5, 3) float64, metres, robot frame: the adapter's proposal for frame t retargeted onto the
        robot (NaN rows where it had none)."""
        self.obj = obj
        """(3,) float64, metres, data frame: the simulated object's centre, or ``None``."""
        self._to_agent = to_agent
        self._agent: np.ndarray | None = None

    def agent_keys(self) -> np.ndarray:
        """(5, 3) float64, metres, data frame: agent-1-equivalent key joints of the robot (computed once)."""
        if self._agent is None:
            self._agent = self._to_agent()
        return self._agent


@runtime_checkable
class AffordanceAdapter(Protocol):
    """The model-dependent parts of the environment (see the module docstring)."""

    @property
    def kind(self) -> str:
        """``"ground_truth"`` or ``"model"`` (reported in ``info``)."""

    def subevent_names(self, label: str, instances: Sequence[Interaction]) -> tuple[str, ...]:
        """Sub-event names of interaction ``label`` (its belief vector's entries), given its instances."""

    def reset(self, interaction: Interaction, *, rng: np.random.Generator | None = None) -> None:
        """Start on a new instance; ``rng`` (from the environment's seed) for adapters that sample."""

    def observe(self, t: int) -> AdapterFrame:
        """Proposal and belief at frame ``t``; ``t`` only ever increases by one after :meth:`reset`
        (a repeated ``t`` must give the same answer). May use agent 0 and the object up to ``t``."""

    def log_likelihood(self, subevent: int, pose: RobotPose) -> AffordanceScore:
        """Score the robot's ``pose`` after a step under sub-event ``subevent`` (−1: unknown)."""


class GroundTruthAdapter:
    """The recording as the adapter: agent 1's key joints, recorded sub-events, a Gaussian proxy score.

    ``sigma`` is σ (metres) of the proxy: log φ = Σ_k log N(x_k; x̂_k, σ²I₃) over the key frames k
    with a reference, x the robot's key frames and x̂ the recording retargeted onto the robot
    (both robot frame, :class:`RobotPose`); its upper bound is the value at x = x̂, so
    (log φ − bound) / n = −mean_k ‖x_k − x̂_k‖² / (2σ²).
    """

    def __init__(self, sigma: float = 0.1) -> None:
        if not float(sigma) > 0:
            raise ConfigError(f"GroundTruthAdapter: argument 'sigma': expected a distance > 0 in metres, found {sigma!r}")
        self.sigma = float(sigma)
        self._keys: np.ndarray | None = None
        self._sub = np.zeros(0, dtype=np.int64)
        self._names: tuple[str, ...] = ()

    @property
    def kind(self) -> str:
        return "ground_truth"

    def subevent_names(self, label: str, instances: Sequence[Interaction]) -> tuple[str, ...]:
        """The longest list of recorded sub-event names among the instances of ``label``."""
        names = [i.subevent_names for i in instances if i.label == label and i.subevents is not None]
        return max(names, key=len) if names else ()

    def reset(self, interaction: Interaction, *, rng: np.random.Generator | None = None) -> None:
        self._keys = interaction.key_joints()[:, 1]
        self._names = interaction.subevent_names
        sub = interaction.subevents
        self._sub = np.full(interaction.n_frames, -1, dtype=np.int64) if sub is None else np.asarray(sub, np.int64)

    def _require(self, t: int) -> np.ndarray:
        if self._keys is None:
            raise SimulationError("GroundTruthAdapter: call reset(interaction) before observe/log_likelihood")
        if not 0 <= t < len(self._keys):
            raise SimulationError(f"GroundTruthAdapter: frame {t} is outside the instance (0 ≤ t < {len(self._keys)})")
        return self._keys

    def observe(self, t: int) -> AdapterFrame:
        keys = self._require(t)
        s = int(self._sub[t])
        belief = np.zeros(len(self._names))
        if s >= 0:
            belief[s] = 1.0
        return AdapterFrame(keys[t].copy(), belief, s, self._names[s] if s >= 0 else None)

    def log_likelihood(self, subevent: int, pose: RobotPose) -> AffordanceScore:
        ref = np.asarray(pose.reference, dtype=np.float64)
        keys = np.asarray(pose.robot_keys, dtype=np.float64)
        if keys.shape != (N_KEY, 3) or ref.shape != (N_KEY, 3):
            raise SimulationError(f"GroundTruthAdapter.log_likelihood: expected (5, 3) key frames and reference, "
                                  f"found {keys.shape} and {ref.shape}")
        ok = np.isfinite(ref).all(axis=1) & np.isfinite(keys).all(axis=1)
        n = int(ok.sum())
        if n == 0:
            return AffordanceScore(0.0, 0.0, 0)
        sq = np.sum((keys[ok] - ref[ok]) ** 2, axis=1)
        log_norm = -1.5 * np.log(2.0 * np.pi * self.sigma**2)
        return AffordanceScore(float(np.sum(log_norm - sq / (2.0 * self.sigma**2))), float(n * log_norm), n)
