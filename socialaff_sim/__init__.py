"""socialaff_sim: learn social affordance from two-person recordings and make a MuJoCo humanoid react.

The pipeline, one sub-package a stage, in one-way layers (each imports only from those before it;
pyproject.toml's import-linter contract, docs/contributing.md): ``data`` → ``model`` → ``learning`` →
``inference`` → ``baselines`` → ``retarget`` → ``sim`` → ``environment`` → ``evaluation`` → ``demo`` → ``cli``.
"""

# First: MuJoCo reads MUJOCO_GL when it is first imported, and every sub-package imports it below this.
from ._headless import GL_CHOICE
from .errors import SocialAffError
from .gym_ids import register_envs

__version__ = "0.1.0"

# Gymnasium ids (socialaff_sim/ShakeHands-v0, …): entry-point strings only, the env loads on gym.make.
register_envs()

__all__ = ["GL_CHOICE", "SocialAffError", "__version__"]
