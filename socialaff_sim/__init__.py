"""socialaff_sim: learn social affordance from two-person recordings and make a MuJoCo humanoid react.

The pipeline, one sub-package a stage:
``data`` → ``model`` → ``learning`` → ``inference`` → ``retarget`` → ``sim`` → ``environment``.
"""

from .errors import SocialAffError

__version__ = "0.1.0"

__all__ = ["SocialAffError", "__version__"]
