"""Inference: full-body fit (and, later, DP parsing and online synthesis of Algorithm 2).

Hook for the evaluation: :func:`socialaff_sim.evaluation.get_method` imports this
package before looking a method up, so the synthesis module should be imported
here and call ``socialaff_sim.evaluation.register_method`` for ``"full"``,
``"v1"`` and ``"v2"`` at import time (with module-level, picklable factories).
"""

from .body_fit import BodyFitConfig, BodyFitter, instance_frame, kmeans, two_bone_ik

__all__ = ["BodyFitConfig", "BodyFitter", "instance_frame", "kmeans", "two_bone_ik"]
