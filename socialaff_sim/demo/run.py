"""The whole demo: every interaction of the embedded synthetic dataset through :func:`~.pipeline.run_interaction`, then the report."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..data.synthetic import INTERACTIONS, generate_dataset
from ..errors import ConfigError, choices
from ..retarget.robot import load_robot
from .pipeline import DemoConfig, InteractionResult, Progress, run_interaction
from .report import write_report

__all__ = ["run_demo"]


def run_demo(
    out: str | Path,
    interactions: Sequence[str] | None = None,
    config: DemoConfig | None = None,
    progress: Progress | None = None,
) -> list[InteractionResult]:
    """The whole demo on the synthetic dataset; writes everything (and ``report.md``) into ``out``."""
    config = config or DemoConfig()
    labels = list(interactions) if interactions else list(INTERACTIONS)
    unknown = [x for x in labels if x not in INTERACTIONS]
    if unknown:
        raise ConfigError(f"demo: unknown interaction {unknown[0]!r}; choose from {choices(INTERACTIONS)}")
    load_robot(config.robot, mjcf=config.mjcf).build_mjcf()  # a robot that cannot be built fails before the learning
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    dataset = generate_dataset(config.seed)
    results = [run_interaction(dataset, label, out, config, progress) for label in labels]
    write_report(out / "report.md", results, config)
    return results
