"""The embedded default dataset: a seeded generator of synthetic HHOI-like interactions.

Five two-person interactions (:data:`INTERACTIONS`) are scripted as sequences of
sub-events (:data:`SUBEVENTS`) performed by eight synthetic actors of different
statures and proportions. Bodies are 25-joint Kinect v2 skeletons built by
forward kinematics from segment lengths, with limbs placed by analytic two-link
IK; contacts (hands meeting, the ball reaching the catcher's palms, the cup
between both palms) are exact in the clean data. Kinect-like jitter and
dropouts are added unless ``SyntheticConfig(noise=False)``.

>>> from socialaff_sim.data.synthetic import generate_dataset
>>> data = generate_dataset(seed=0)          # 5 × 24 instances, a few seconds each
>>> data.of_label("throw_catch")[0].object.shape[1]
3
"""

from .body import Actor, BodyTrack, forward_kinematics, make_actors
from .config import INTERACTIONS, SUBEVENTS, SyntheticConfig
from .generator import SCRIPTS, actor_pairs, generate_actors, generate_dataset, generate_instance
from .objects import BALL_RADIUS, CUP_RADIUS, GRAVITY

__all__ = [
    "Actor",
    "BALL_RADIUS",
    "BodyTrack",
    "CUP_RADIUS",
    "GRAVITY",
    "INTERACTIONS",
    "SCRIPTS",
    "SUBEVENTS",
    "SyntheticConfig",
    "actor_pairs",
    "forward_kinematics",
    "generate_actors",
    "generate_dataset",
    "generate_instance",
    "make_actors",
]
