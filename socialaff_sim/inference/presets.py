"""Named bundles of the three configurations: this project's defaults and the paper's exact settings.

``preset("paper")`` is the model (section 3), Algorithm 1 (section 4) and Algorithm 2 (section 5) of
Shu, Ryoo & Zhu, IJCAI 2016, as this project reads them; ``preset("default")`` is the project's model,
learner and synthesizer. docs/design.md lists every difference between the two with its measured effect.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ..errors import ConfigError, choices
from ..learning.config import LearningConfig
from ..model.config import AffordanceConfig
from .synthesis_config import SynthesisConfig

__all__ = ["PRESETS", "Preset", "preset"]


@dataclass(frozen=True)
class Preset:
    """The settings of the three stages, used together."""

    affordance: AffordanceConfig
    """The model (:class:`~socialaff_sim.model.config.AffordanceConfig`)."""
    learning: LearningConfig
    """Algorithm 1 (:class:`~socialaff_sim.learning.config.LearningConfig`)."""
    synthesis: SynthesisConfig
    """Algorithm 2 (:class:`~socialaff_sim.inference.synthesis_config.SynthesisConfig`)."""


_BUILDERS: dict[str, Callable[[], Preset]] = {
    "default": lambda: Preset(AffordanceConfig(), LearningConfig(), SynthesisConfig()),
    "paper": lambda: Preset(AffordanceConfig.paper(), LearningConfig.paper(), SynthesisConfig.paper()),
}

PRESETS: tuple[str, ...] = tuple(_BUILDERS)
"""The valid preset names."""


def preset(name: str) -> Preset:
    """The configurations of preset ``name`` (one of :data:`PRESETS`)."""
    if name not in _BUILDERS:
        raise ConfigError(f"preset: expected {choices(PRESETS)}, found {name!r}")
    return _BUILDERS[name]()
