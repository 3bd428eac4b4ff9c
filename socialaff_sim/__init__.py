"""socialaff_sim: learn social affordance from two-person recordings and make a MuJoCo humanoid react.

The pipeline, one sub-package a stage, in one-way layers (each imports only from those before it;
pyproject.toml's import-linter contract, docs/contributing.md): ``data`` → ``model`` → ``learning`` →
``inference`` → ``baselines`` → ``retarget`` → ``sim`` → ``environment`` → ``evaluation`` → ``demo`` → ``cli``.
"""

from .errors import SocialAffError

__version__ = "0.1.0"

__all__ = ["SocialAffError", "__version__"]
