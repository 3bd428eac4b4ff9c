"""Settings of the learning algorithm (Shu, Ryoo & Zhu, IJCAI 2016, section 4, Algorithm 1)."""

from __future__ import annotations

from dataclasses import dataclass

from .._config import DictConfig
from ..errors import ConfigError

__all__ = ["LearningConfig"]


@dataclass(frozen=True)
class LearningConfig(DictConfig):
    """Algorithm 1 settings; change them with ``dataclasses.replace``.

    The defaults are this project's learner; :meth:`paper` gives Algorithm 1 as the paper states it
    (K-means atoms, then Metropolis-Hastings with merge 0.4 / split 0.4 / relabel 0.2 at temperature 1,
    no hard-EM start, no type restructuring, no shift move).

    Fields by concept
    -----------------
    - Atomic time intervals: n_clusters, kmeans_iterations, min_atomic_frames, max_atomic_seconds, velocity_seconds
    - Initial parses: init_rounds, init_starts, init_type_passes, init_type_rounds, init_type_screen_rounds,
      init_dirichlet
    - Outer loop: Metropolis-Hastings over parses: iterations, p_merge, p_split, p_relabel, p_shift, temperature, lam
    - Inner loop: Gibbs sampling of the groupings: gibbs_max_sweeps, gibbs_patience, initial_gibbs_sweeps
    """

    iterations: int = 0
    """I [—]: Outer iterations. One iteration is a sweep of Metropolis-Hastings proposals, one per training
    instance in turn, each followed by the inner Gibbs loop on the sub-event types it touches. 0 (default): the
    initial parse (hard-EM and the type restructuring) is the fit, because after it the chain never rose above its
    start on any shared set and 100 iterations left the development-split error unchanged within noise at 2–2.7×
    the fit time (docs/design.md §8); :meth:`paper` runs 100, the paper's."""
    n_clusters: int = 50
    """K [—]: K of the K-means over all training frames that defines the atomic time intervals."""
    kmeans_iterations: int = 50
    """[—]: Most Lloyd iterations of that K-means (it stops earlier when the assignment is stable)."""
    min_atomic_frames: int = 2
    """[frames]: Runs of one cluster shorter than this many frames are merged into the more similar neighbour."""
    max_atomic_seconds: float = 0.3
    """[s]: Atoms longer than this (seconds) are cut into equal parts, so that boundaries can be placed finely."""
    velocity_seconds: float = 0.5
    """τ [s]: weight of the joint velocities (m/s × τ) against the positions (m) in the K-means features."""
    init_rounds: int = 10
    """[—]: Most rounds of hard-EM (fit, then DP re-segmentation) refining the equal-part initial parses, our
    addition (0, the paper: start the chain from the equal parts of the atoms)."""
    init_starts: int = 0
    """[—]: Extra starting points of the initial parses, our addition: besides the |S| equal parts, this many
    splits of every instance into |S| consecutive parts with fractions drawn from a symmetric
    Dirichlet(``init_dirichlet``) (one draw shared by all instances, from the caller's Generator). Each
    start is refined by hard-EM and the one with the highest log P* seeds the chain. The chain's local
    moves rarely cross between the basins different starts reach. 0 (default): the equal parts only."""
    init_type_passes: int = 3
    """[—]: Most passes of type-level merge-and-split moves on the best initial parses, our addition
    (:mod:`~socialaff_sim.learning.restructure`): merge two adjacent types and split a third in every
    instance at once, refine by hard-EM, keep it if log P* rises. 0 (the paper): none."""
    init_type_rounds: int = 3
    """[—]: Hard-EM rounds refining each candidate of those moves."""
    init_type_screen_rounds: int = 1
    """[—]: Of those rounds, how many every candidate of a pass gets before the candidates are ranked by log P* (the
    three best then get the rest, ``init_type_rounds`` minus these). 1 (default): one. 0: the candidates are ranked
    by the log P* of their merge-and-split parses as they are, and only the three best are refined (issue 24: a
    cheaper fit; a model change, docs/design.md §8, "Screening the restructuring's candidates without a hard-EM
    round")."""
    init_dirichlet: float = 2.0
    """[—]: Concentration of the Dirichlet that draws the fractions of the extra starts."""
    p_merge: float = 0.4
    """q(Q1) [—]: Probability of the merge dynamics Q1 (given that no shift was drawn)."""
    p_split: float = 0.4
    """q(Q2) [—]: Probability of the split dynamics Q2 (given that no shift was drawn)."""
    p_relabel: float = 0.2
    """q(Q3) [—]: Probability of the relabel dynamics Q3 (given that no shift was drawn)."""
    p_shift: float = 0.5
    """[—]: Probability of the boundary-shift dynamics, our addition: a parse boundary moves to a neighbouring
    atomic boundary (a merge immediately followed by a split of the merged interval, labels kept).
    Otherwise one of the paper's dynamics is drawn with p_merge / p_split / p_relabel. 0 (the paper):
    no shift move."""
    temperature: float = 1000.0
    """T₀ [—]: the tempered chain's first temperature (≥ 1), our addition: iteration i of I accepts with
    min(1, (P*'/P*)^(1/T_i) q_rev/q_fwd), T_i = T₀^(1 − i/(I − 1)) cooling geometrically to 1 at the
    last iteration (simulated annealing; the returned state is the best visited). A one-atom change of
    one instance's parse moves log P* by tens to thousands of nats on the synthetic data (a merge, in the median,
    by about −750), so at T = 1 the default chain accepts almost nothing; 1000 is the smallest of 100, 300, 1000
    at which every dynamics is accepted at all (docs/design.md). 1 (the paper): no tempering."""
    lam: float = 1.0
    """λ [—]: λ of the proposals (the same in both presets; the paper names λ without a value): a split picks
    atomic boundary b with probability ∝ exp(λ d_b), a merge picks a
    parse boundary with probability ∝ exp(−λ d_b), d_b ∈ [0, 1] the normalized motion change at b."""
    gibbs_max_sweeps: int = 10
    """[—]: Most Gibbs sweeps of the inner loop over Z^s per sub-event type and proposal."""
    gibbs_patience: int = 2
    """[—]: The inner loop stops when a sweep changes nothing or the best joint probability has not improved
    for this many sweeps."""
    initial_gibbs_sweeps: int = 30
    """[—]: Most Gibbs sweeps for each type on the initial parse (same stopping rule)."""

    def __post_init__(self) -> None:
        def bad(name: str, expected: str) -> ConfigError:
            return ConfigError(f"LearningConfig.{name}: expected {expected}, found {getattr(self, name)!r}")

        for name in ("n_clusters", "kmeans_iterations", "min_atomic_frames", "gibbs_max_sweeps",
                     "gibbs_patience", "initial_gibbs_sweeps"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 1:
                raise bad(name, "an integer >= 1")
        for name in ("iterations", "init_rounds", "init_starts", "init_type_passes", "init_type_rounds",
                     "init_type_screen_rounds"):
            if not isinstance(getattr(self, name), int) or getattr(self, name) < 0:
                raise bad(name, "an integer >= 0")
        probs = (self.p_merge, self.p_split, self.p_relabel)
        if min(probs) < 0 or abs(sum(probs) - 1.0) > 1e-9:
            raise bad("p_merge", f"p_merge + p_split + p_relabel = 1 with each >= 0 (found {probs})")
        if not 0.0 <= self.p_shift < 1.0:
            raise bad("p_shift", "a probability in [0, 1)")
        if not self.max_atomic_seconds > 0:
            raise bad("max_atomic_seconds", "a number > 0")
        if self.velocity_seconds < 0:
            raise bad("velocity_seconds", "a number >= 0")
        if not self.init_dirichlet > 0:
            raise bad("init_dirichlet", "a number > 0")
        if self.lam < 0:
            raise bad("lam", "a number >= 0")
        if not float(self.temperature) >= 1.0:
            raise bad("temperature", "a number >= 1")

    @classmethod
    def paper(cls, **changes: object) -> LearningConfig:
        """Algorithm 1 as the paper states it: the equal parts of the K-means atoms as the start, then
        Metropolis-Hastings with merge 0.4 / split 0.4 / relabel 0.2 at temperature 1 for 100 iterations and the
        inner Gibbs loop; no hard-EM start, no type restructuring, no shift move, no extra starts."""
        base: dict[str, object] = dict(
            iterations=100, init_rounds=0, init_starts=0, init_type_passes=0, p_shift=0.0, temperature=1.0,
            p_merge=0.4, p_split=0.4, p_relabel=0.2,
        )
        return cls(**{**base, **changes})  # type: ignore[arg-type]
