"""The main job end to end on the embedded synthetic dataset: learn, synthesize, simulate, report."""

from .pipeline import DemoConfig, InteractionResult, run_interaction
from .report import write_report
from .run import run_demo

__all__ = ["DemoConfig", "InteractionResult", "run_demo", "run_interaction", "write_report"]
