"""Shared fixtures: the real recordings beside the project, and explicit seeds."""

from __future__ import annotations

import os
import sys
import types
from pathlib import Path

# Offscreen rendering on headless machines; must be set before mujoco is imported.
os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

SHARED_DATA = Path(os.environ.get("SOCIALAFF_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))


def shared_path(*parts: str) -> Path:
    """Path under ../shared/data; skips the test with a reason when it is absent."""
    path = SHARED_DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"real recordings not available at {path} (they live in ../shared/data beside the project)")
    return path


@pytest.fixture
def seed(request: pytest.FixtureRequest) -> int:
    """An explicit seed, printed so a failure can be replayed."""
    marker = request.node.get_closest_marker("seed")
    value = int(marker.args[0]) if marker else 12345
    print(f"seed = {value}")
    return value


@pytest.fixture
def rng(seed: int) -> np.random.Generator:
    """A Generator seeded from :func:`seed`."""
    return np.random.default_rng(seed)


@pytest.fixture
def fake_rospy(monkeypatch: pytest.MonkeyPatch) -> type:
    """A stand-in ``rospy.rostime.Time`` (state [secs, nsecs], like genpy) so tests can write such pickles."""

    class Time:
        def __init__(self, secs: int, nsecs: int) -> None:
            self.secs, self.nsecs = secs, nsecs

        def __getstate__(self) -> list[int]:
            return [self.secs, self.nsecs]

        def __setstate__(self, state: list[int]) -> None:
            self.secs, self.nsecs = state

    Time.__module__, Time.__qualname__ = "rospy.rostime", "Time"
    rospy, rostime = types.ModuleType("rospy"), types.ModuleType("rospy.rostime")
    rostime.Time = Time  # type: ignore[attr-defined]
    rospy.rostime = rostime  # type: ignore[attr-defined]
    monkeypatch.setitem(sys.modules, "rospy", rospy)
    monkeypatch.setitem(sys.modules, "rospy.rostime", rostime)
    return Time
