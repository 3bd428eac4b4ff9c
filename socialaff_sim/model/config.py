"""Settings of the social affordance model (Shu, Ryoo & Zhu, IJCAI 2016, section 3)."""

from __future__ import annotations

from dataclasses import dataclass

from .._config import DictConfig
from ..data.synthetic.config import SUBEVENTS
from ..errors import ConfigError, choices
from .path import PATH_PROFILES

__all__ = ["AffordanceConfig", "DEFAULT_N_SUBEVENTS", "DURATION_DENSITIES", "LIKELIHOODS", "VECTOR_DENSITIES", "default_n_subevents"]

LIKELIHOODS = ("profile", "held_out")
"""Valid values of :attr:`AffordanceConfig.likelihood`."""

DURATION_DENSITIES = ("seconds", "log_seconds")
"""Valid values of :attr:`AffordanceConfig.duration_density`."""

VECTOR_DENSITIES = ("polar", "cartesian")
"""Valid values of :attr:`AffordanceConfig.vector_density`."""

DEFAULT_N_SUBEVENTS = 4
"""|S| used when neither the config nor the synthetic dataset names one for an interaction."""


@dataclass(frozen=True)
class AffordanceConfig(DictConfig):
    """Model settings; change them with ``dataclasses.replace``.

    The defaults are this project's model; :meth:`paper` gives the model of the paper (Shu, Ryoo &
    Zhu, IJCAI 2016, section 3). Every field on which the two differ says so, and docs/design.md lists
    the differences with their measured effects.

    Fields by concept
    -----------------
    - Sub-events and parses: n_subevents, transition_alpha, start_prior, distinct_neighbours, unique_labels,
      min_subevent_seconds
    - Joint selection and grouping: beta, gamma, other_side_reference, reference_self
    - Potentials and durations: vector_density, duration_density
    - Maximum-likelihood fits: eps, shape_min, shape_max, kappa_max, sigma_min
    - Learning objective P*: likelihood
    - Ablations V1 and V2: use_grouping, use_subevents
    - Path noise (our addition): path_noise, path_profile, path_sigma_min
    - Handedness (our addition): active_hand
    - Learned for synthesis (our additions): end_sigma_min, contact_radius, n_observed
    """

    n_subevents: int | None = None
    """|S| [—]: the size of the sub-event dictionary of the interaction. ``None``: the number of
    ground-truth sub-events of the synthetic dataset for that label when it has one, else
    :data:`DEFAULT_N_SUBEVENTS` (see :func:`default_n_subevents`)."""
    beta: float = 0.3
    """β [—]: the Bernoulli probability that a key joint is selected (affordable, not Null)."""
    gamma: float = 1.0
    """γ [—]: the concentration of the Chinese-restaurant-process prior over functional groups."""
    transition_alpha: float = 1.0
    """α [—]: add-α smoothing of the transition frequencies p(s_k | s_{k−1}) and of the start distribution."""
    other_side_reference: bool = True
    """[—]: A grouped joint's spatial reference is the mass centre of its group mates on the *other* side of the
    interaction (the other agent's joints and the object; for the object, both agents' joints), so a group
    expresses relations between the agents rather than one body's posture (our change). False: all group
    mates (the paper)."""
    reference_self: bool = False
    """[—]: Whether the mass centre a grouped joint is placed relative to includes the joint itself. The paper
    defines the reference as the mass centre of the joint's group, the joint included (True); the
    default leaves it out (False), so the offset is the joint's position relative to its mates, not
    shrunk by (M − 1) / M with the group's size M. A joint alone in its group is placed relative to
    the other agent's base in both (a one-joint group's own mass centre is the joint: a zero offset)."""
    start_prior: bool = True
    """p(s_1) [—]: Learn the start distribution p(s_1) from the first labels of the training parses (add-α); our
    addition, used by the learning objective, the DP parses and the online parse. False (the paper,
    whose parse probability has the transitions p(s_k | s_{k−1}) only): p(s_1) uniform."""
    use_grouping: bool = True
    """[—]: False gives ablation V1 ("no joint selection and grouping"): Z is not learned; every available
    key joint is affordable and lone (spatial potential relative to the other agent's base, Weibull/von
    Mises motion potential) and the grouping prior is dropped."""
    use_subevents: bool = True
    """[—]: False gives ablation V2 ("no latent sub-events"): |S| = 1, one sub-event spans each whole
    instance, and no Metropolis-Hastings over parses is run."""
    distinct_neighbours: bool = True
    """[—]: Consecutive intervals of a parse carry different labels (a sub-event is a maximal interval)."""
    unique_labels: bool = True
    """[—]: Each sub-event type occupies at most one interval of an instance (our constraint: an interaction
    read as a sequence of distinct sub-events such as approach, reach, shake, retract). False (the
    paper, which puts no such constraint on parses): a type may recur."""
    min_subevent_seconds: float = 0.0
    """[s]: Shortest allowed sub-event interval, seconds (0: no limit)."""
    eps: float = 1e-3
    """ε [m]: floor of every distance fed to a Weibull or exponential (1 mm)."""
    shape_min: float = 0.3
    """k_min [—]: Lower clamp of a fitted Weibull shape k."""
    shape_max: float = 20.0
    """k_max [—]: Upper clamp of a fitted Weibull shape k (reached by N = 1 or identical samples)."""
    kappa_max: float = 200.0
    """κ_max [—]: Cap of a fitted von Mises concentration κ (reached by N = 1 or identical angles)."""
    sigma_min: float = 0.05
    """σ_min [log s]: Floor of the fitted log-normal σ of sub-event durations (log-seconds)."""
    likelihood: str = "profile"
    """[—]: How the learning objective P* scores the training samples of a type under its potentials and
    duration prior. ``"profile"`` (the paper): Σ_n log p(x_n | θ̂), θ̂ the maximum-likelihood fit to the
    same samples — it rewards parses whose samples a fit can hug (tiny, near-identical intervals, a
    Weibull shape or κ pushed to its cap); the default. ``"held_out"``: the leave-one-instance-out
    predictive log-likelihood Σ_n log p(x_n | θ̂_−n), θ̂_−n fitted without sample n (with one interval
    per type and instance, that is without instance n); a type with one sample keeps the profile
    value. The learned parameters are the full-sample ML fits in both cases."""
    duration_density: str = "seconds"
    """[—]: What the log-normal duration prior is a density of. ``"seconds"`` (the paper): of the duration
    x in seconds, f(x) = exp(−(log x − μ)²/2σ²) / (x σ √(2π)); its 1/x factor makes every short interval
    likelier than a long one of the same relative spread, so splitting a motion into tiny pieces is
    rewarded. ``"log_seconds"``: of log x (the normal N(μ, σ²), i.e. x f(x)), which scores
    durations by their relative spread only."""
    vector_density: str = "polar"
    """[—]: What the spatial and motion potentials are densities of. ``"polar"`` (the paper's product): of
    (h, |dz|, θ), the horizontal distance, vertical distance and angle of the vector (a joint's offset
    from its reference, or its displacement). ``"cartesian"``: of the vector itself, i.e. the polar
    product times the Jacobian 1 / (2h) (the polar map has Jacobian h; |dz| folds ±dz). Different
    groupings put a joint's end position relative to different reference points, so only the
    Cartesian form compares densities of the same position in the inner loop; the polar form rewards
    far references (a tight contact offset has an ill-defined angle and gains nothing from being small)."""

    path_noise: bool = True
    """[—]: Our addition, on by default: also generate the frames inside each sub-event, as Gaussian noise
    (σ_sj per type s and joint j, maximum likelihood) around the path between the sub-event's ends
    (:mod:`~socialaff_sim.model.path`). The paper's potentials see only the two end configurations
    of a sub-event, so its objective cannot tell where the motion in between belongs: on the
    synthetic dataset it scores parses that lump a reach-and-return into one interval and cut
    still moments into tiny ones above the ground truth (frame accuracy 0.63 against 0.90 with this
    term; docs/design.md). False: the paper (no such term)."""
    path_profile: str = "minjerk"
    """[—]: Time profile of that path (:data:`~socialaff_sim.model.path.PATH_PROFILES`): ``"minjerk"``, a
    minimum-jerk movement from rest to rest, or ``"linear"``, constant speed."""
    path_sigma_min: float = 0.01
    """[m]: Floor of a fitted path-noise σ, metres (1 cm, about the skeleton noise)."""
    end_sigma_min: float = 0.01
    """σ_min [m]: σ_min of the end-configuration and frame regressions' residual covariances, metres (our addition,
    used by synthesis only; :mod:`~socialaff_sim.model.end_regression`, :mod:`~socialaff_sim.model.frame_regression`)."""
    active_hand: bool = True
    """[—]: Our addition, on by default: per instance and agent, relabel the left and right key joints so the
    wrist that travels farther is "right" (:mod:`~socialaff_sim.model.handedness`). Actors who use
    either hand then share one joint grouping per sub-event (contact wrists grouped in 5 of 5 synthetic
    interactions against 3 of 5 without; docs/design.md). False: the paper, labels as recorded."""
    contact_radius: float = 0.2
    """[m]: our addition (used by synthesis only): an approach of agent 1's wrist to a group mate inside a
    sub-event is learned as a contact keyframe when its mean closest distance is below this and the mean
    distance at the interval's end is not (:mod:`~socialaff_sim.model.contact_keys`)."""
    n_observed: int = 10
    """T0 [frames]: our addition (used by synthesis only): the regressions read agent 1 at frame T0 − 1 of each
    training instance, the last frame observed before synthesis starts (the paper's evaluation observes
    T0 = 10; a synthesizer with another T0 reads its own last observed frame)."""

    @classmethod
    def paper(cls, **changes: object) -> AffordanceConfig:
        """The paper's model exactly (section 3): the reference of a grouped joint is the mass centre of its
        whole group, joint included; p(s_1) uniform; no unique-label constraint; no path-noise term; left and
        right as recorded. Everything else (β, γ, the Weibull/von Mises potentials of (h, |dz|, θ), the
        profile likelihood, the log-normal density of durations in seconds) is the same in both."""
        base: dict[str, object] = dict(
            other_side_reference=False, reference_self=True, start_prior=False, unique_labels=False,
            path_noise=False, active_hand=False,
        )
        return cls(**{**base, **changes})  # type: ignore[arg-type]

    @property
    def feature_path_profile(self) -> str | None:
        """The path profile interval features must carry: ``path_profile`` with path noise on, else None."""
        return self.path_profile if self.path_noise else None

    def __post_init__(self) -> None:
        def bad(name: str, expected: str) -> ConfigError:
            return ConfigError(f"AffordanceConfig.{name}: expected {expected}, found {getattr(self, name)!r}")

        if self.n_subevents is not None and (not isinstance(self.n_subevents, int) or self.n_subevents < 1):
            raise bad("n_subevents", "None or an integer >= 1")
        if not 0.0 < self.beta < 1.0:
            raise bad("beta", "a probability in (0, 1)")
        for name in ("gamma", "eps", "shape_min", "shape_max", "kappa_max", "sigma_min", "path_sigma_min", "end_sigma_min", "contact_radius"):
            if not float(getattr(self, name)) > 0:
                raise bad(name, "a number > 0")
        if not isinstance(self.n_observed, int) or self.n_observed < 1:
            raise bad("n_observed", "an integer >= 1 (frames)")
        if self.transition_alpha < 0:
            raise bad("transition_alpha", "a number >= 0")
        if self.min_subevent_seconds < 0:
            raise bad("min_subevent_seconds", "a number >= 0 (seconds)")
        if self.likelihood not in LIKELIHOODS:
            raise ConfigError(
                f"AffordanceConfig.likelihood: expected {choices(LIKELIHOODS)}, found {self.likelihood!r}"
            )
        if self.duration_density not in DURATION_DENSITIES:
            raise ConfigError(
                f"AffordanceConfig.duration_density: expected {choices(DURATION_DENSITIES)}, found {self.duration_density!r}"
            )
        if self.vector_density not in VECTOR_DENSITIES:
            raise ConfigError(
                f"AffordanceConfig.vector_density: expected {choices(VECTOR_DENSITIES)}, found {self.vector_density!r}"
            )
        if self.path_profile not in PATH_PROFILES:
            raise ConfigError(
                f"AffordanceConfig.path_profile: expected {choices(PATH_PROFILES)}, found {self.path_profile!r}"
            )
        if self.shape_min >= self.shape_max:
            raise bad("shape_min", f"a value below shape_max = {self.shape_max}")


def default_n_subevents(label: str) -> int:
    """|S| for an interaction label: the synthetic dataset's sub-event count if it defines the label, else 4."""
    if label in SUBEVENTS:
        return max(1, len(SUBEVENTS[label]))
    return DEFAULT_N_SUBEVENTS
