"""Learning the affordance model: Algorithm 1 of Shu, Ryoo & Zhu (IJCAI 2016, section 4).

:class:`SocialAffordanceModel` (:mod:`.estimator`) is the model users fit: settings in the
constructor, ``fit(interactions, rng=...) -> self`` runs the steps below, ``save``/``load`` use the
model file of :mod:`.model_io`. Its learned parameters are an
:class:`~socialaff_sim.model.affordance.AffordanceParameters` (one layer down).

1. Atomic time intervals (:mod:`.atomic`): K-means (50 clusters) over all training frames,
   runs of one cluster, short runs merged and long ones cut.
2. Initial parses (:mod:`.initial`): |S| equal parts labelled in order, refined by hard-EM
   (fit, then dynamic-programming re-segmentation) — our addition, see below; optionally also
   ``LearningConfig.init_starts`` random-fraction splits, the refinement with the highest log P* kept.
3. Outer loop (:mod:`.mh`): Metropolis-Hastings over parses with the paper's merge / split /
   relabel dynamics (0.4 / 0.4 / 0.2, λ = 1) plus, in the default, a boundary-shift dynamics, relabels
   that swap two labels under the one-interval-per-type constraint, and tempering (T₀ = 1000 cooled to 1);
   exact reverse-move probabilities in the acceptance ratio. One iteration = one proposal per training
   instance; ``history_`` records every dynamics' proposals and acceptances per iteration (:mod:`.history`).
4. Inner loop (:mod:`.gibbs`): Gibbs sampling of every z^s_ai for the sub-event types a
   proposal touches, warm-started, until a sweep changes nothing or the best joint probability
   stalls; P*(parse) is the best value found (:mod:`.scorer`, incremental statistics).

Why the additions: with one interval per sub-event type (the default) a split has no admissible
choice once every instance uses all |S| labels, and a merge (or a split) changes the number of samples
of a type, which the maximized likelihood punishes by hundreds of nats; so at temperature 1 the chain
does not move. The shift dynamics moves a boundary in one step, and the hard-EM start moves all
instances' parses together. :meth:`LearningConfig.paper` is Algorithm 1 without any of them
(docs/design.md measures each).
"""

from .algorithm import FitProgress, LearningResult, learn
from .config import LearningConfig
from .estimator import SocialAffordanceModel, load_model
from .mh import FunctionTarget, ParseTarget, mh_step, propose
from .model_io import MODEL_FORMAT_VERSION, save_model
from .parse import Parse, ParseSpace, enumerate_parses

__all__ = [
    "FitProgress",
    "FunctionTarget",
    "LearningConfig",
    "LearningResult",
    "MODEL_FORMAT_VERSION",
    "Parse",
    "ParseSpace",
    "ParseTarget",
    "SocialAffordanceModel",
    "enumerate_parses",
    "learn",
    "load_model",
    "mh_step",
    "propose",
    "save_model",
]
