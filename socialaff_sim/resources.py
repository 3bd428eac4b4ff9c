"""Locate the shipped MJCF assets and task files, installed or in a checkout."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from .errors import ConfigError, choices

__all__ = ["assets_dir", "envs_dir", "asset_path", "task_file_path"]


def _locate(packaged: str, checkout: str) -> Path:
    # A wheel carries the folders inside the package (see pyproject's force-include);
    # an editable install or a plain checkout has them at the repository's top level.
    inside = Path(str(resources.files("socialaff_sim"))) / packaged
    if inside.is_dir():
        return inside
    top = Path(__file__).resolve().parent.parent / checkout
    if top.is_dir():
        return top
    raise ConfigError(
        f"cannot find the {checkout}/ folder: looked in {inside} and {top}; "
        "reinstall the package (pip install socialaff-sim)"
    )


def assets_dir() -> Path:
    """The folder holding the MJCF models (``assets/``)."""
    return _locate("_assets", "assets")


def envs_dir() -> Path:
    """The folder holding the declarative task files (``envs/``)."""
    return _locate("_envs", "envs")


def asset_path(name: str) -> Path:
    """Path of a file in ``assets/``; raises :class:`ConfigError` listing what exists."""
    path = assets_dir() / name
    if not path.exists():
        present = sorted(p.name for p in assets_dir().iterdir())
        raise ConfigError(f"no asset {name!r} in {assets_dir()}; available: {choices(present)}")
    return path


def task_file_path(name: str) -> Path:
    """Path of the task file ``envs/<name>.toml``; raises listing the known tasks."""
    path = envs_dir() / f"{name}.toml"
    if not path.exists():
        present = sorted(p.stem for p in envs_dir().glob("*.toml"))
        raise ConfigError(f"no task file for {name!r} in {envs_dir()}; available: {choices(present)}")
    return path
