"""The social affordance model (Shu, Ryoo & Zhu, IJCAI 2016, section 3), one per interaction.

Reading of the paper used here (each point is documented in the module named):

* **Joints** (:mod:`.joints`): five key joints per agent plus the object, index ``5 a + k``
  and 10; joints the data lack are *absent* (fixed out of the grouping, no potential).
* **Canonical frame** (:mod:`.frame`): fixed at an instance's first frame — origin at agent 0's
  base on the floor, x horizontally toward agent 1's base, z up.
* **Parse**: consecutive intervals covering all frames with sub-event labels in 0..|S|−1;
  by default consecutive labels differ and each type occurs at most once per instance
  (:class:`.config.AffordanceConfig`).
* **Grouping** Z^s (:mod:`.grouping`): Bernoulli(β) selection times a CRP(γ) partition.
* **Potentials** (:mod:`.potentials`): spatial (Weibull horizontal and vertical distance, von
  Mises angle) of each affordable joint at a sub-event's last frame relative to the mass centre
  of its group mates on the other side of the interaction (or, alone, the other agent's base;
  the object alone: the midpoint of the bases); motion (the displacement from the frame before
  the sub-event to its last frame): Weibull/Weibull/von Mises for affordable joints,
  exponential/exponential/von Mises for Null joints.
* **Durations** log-normal in seconds; start and transition frequencies with add-α smoothing
  (:mod:`.transitions`); p(c) uniform (a constant).
* Parameters are maximum-likelihood fits (:mod:`.densities`) with documented floors.

:class:`AffordanceParameters` holds the learned parameters; the estimator that learns them with
Algorithm 1, :class:`socialaff_sim.learning.SocialAffordanceModel`, and the model file live one
layer up in :mod:`socialaff_sim.learning`.
"""

from .affordance import AffordanceParameters
from .config import DEFAULT_N_SUBEVENTS, AffordanceConfig, default_n_subevents
from .features import IntervalFeatures, interval_features
from .frame import CanonicalFrame, canonical_frame
from .joints import JOINT_NAMES, N_JOINTS, OBJECT, canonical_joints, instance_frame
from .potentials import TypePotentials
from .segment_dp import best_segmentation

__all__ = [
    "AffordanceConfig",
    "AffordanceParameters",
    "CanonicalFrame",
    "DEFAULT_N_SUBEVENTS",
    "IntervalFeatures",
    "JOINT_NAMES",
    "N_JOINTS",
    "OBJECT",
    "TypePotentials",
    "best_segmentation",
    "canonical_frame",
    "canonical_joints",
    "default_n_subevents",
    "instance_frame",
    "interval_features",
]
