"""Shared fixtures: the real recordings beside the project, and explicit seeds."""

from __future__ import annotations

import copy
import dataclasses
import importlib.util
import os
import sys
import types
import warnings
from pathlib import Path

# Offscreen rendering on headless machines; must be set before mujoco is imported.
os.environ.setdefault("MUJOCO_GL", "egl")

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from gymnasium.utils.env_checker import check_env  # noqa: E402

from socialaff_sim.errors import ConfigError  # noqa: E402
from socialaff_sim.sim.footlock import FootLock, FootLockConfig  # noqa: E402

SHARED_DATA = Path(os.environ.get("SOCIALAFF_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))


def load_script(name: str) -> types.ModuleType:
    """Import ``scripts/<name>.py`` as a module (the library never imports its scripts).

    The module is in ``sys.modules`` while it executes, because dataclasses look their module up.
    """
    path = Path(__file__).resolve().parents[1] / "scripts" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"{name}_script", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
    finally:
        sys.modules.pop(spec.name, None)
    return module


def belief_track(rng: np.random.Generator, T: int) -> np.ndarray:
    """(T, 11, 3) m: a random-walk skeleton track for the belief's tests; joint 10 (the object, which the model
    lacks) is NaN throughout, as in the reactor's track."""
    x = np.cumsum(rng.normal(scale=0.02, size=(T, 11, 3)), axis=0) + rng.normal(scale=0.3, size=(1, 11, 3))
    x[:, 10] = np.nan
    return x


def model_with(base, **changes):  # noqa: ANN001, ANN201
    """A shallow copy of a fitted model whose ``config`` has ``changes`` (``dataclasses.replace``)."""
    m = copy.copy(base)
    if changes:
        m.config = dataclasses.replace(m.config, **changes)
    return m


def parsed_settings(script: types.ModuleType, monkeypatch: pytest.MonkeyPatch, argv: list[str]):  # noqa: ANN201
    """The settings scripts/train_residual.py's ``main`` (``script``, from :func:`load_script`) parses from the
    command line ``argv`` (without the program's name): its ``run`` is replaced by one that keeps them and stops
    with a ConfigError, which ``main`` turns into an exit."""
    seen = {}

    def stop(settings, *args, **kwargs):  # noqa: ANN001, ANN002, ANN003, ANN202
        seen["settings"] = settings
        raise ConfigError("stop")
    monkeypatch.setattr(script, "run", stop)
    monkeypatch.setattr("sys.argv", ["train_residual.py", *argv])
    with pytest.raises(SystemExit):
        script.main()
    return seen["settings"]


def check_env_strict(env: gym.Env) -> None:
    """Gymnasium's env checker on ``env.unwrapped`` with every warning an error (the project's rule for its envs)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)


def shared_path(*parts: str) -> Path:
    """Path under ../shared/data; skips the test with a reason when it is absent."""
    path = SHARED_DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"real recordings not available at {path} (they live in ../shared/data beside the project)")
    return path


SHARED_ROBOTS = Path(os.environ.get("SOCIALAFF_SHARED_ROBOTS", Path(__file__).resolve().parents[2] / "shared" / "robots"))


def standing_with(part: str, **fields: object):  # noqa: ANN201 (SimConfig, imported lazily)
    """``SimConfig.standing()`` with ``fields`` of its config ``part`` ("balance", "stance" or "foot_lock")
    replaced."""
    import dataclasses

    from socialaff_sim.sim.sim_config import SimConfig

    cfg = SimConfig.standing()
    return dataclasses.replace(cfg, **{part: dataclasses.replace(getattr(cfg, part), **fields)})


def synthetic_instance(label: str, k: int):  # noqa: ANN201 (Interaction, imported lazily)
    """Instance ``k`` (0-based: ``synthetic_instance("high_five", 144)`` is high_five_144) of ``label`` in the
    embedded synthetic dataset, seed 0, generated with that interaction alone as the physics tests name them."""
    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset

    return list(generate_dataset(0, SyntheticConfig(interactions=(label,), instances_per_interaction=k + 1)))[k]


def frame_states(cfg, inter) -> list[np.ndarray]:  # noqa: ANN001 (SimConfig, Interaction: imported lazily)
    """The robot's and the scene's state (qpos, qvel, ctrl concatenated) after every frame of a ground-truth episode
    of ``inter`` on Stubby under ``cfg``: for checks that an option leaves a robot bit for bit as it was."""
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import Simulator

    sim = Simulator("ours", inter.label, cfg)
    states: list[np.ndarray] = []
    run_episode(sim, GroundTruthSource(), inter,
                on_frame=lambda s, r, e: states.append(np.concatenate([s.data.qpos, s.data.qvel, s.data.ctrl])))
    return states


def assert_gate_keeps_stubby(inter, base, gated, ungated) -> None:  # noqa: ANN001 (Interaction, SimConfig × 3)
    """A robot-gated option's check on Stubby: its states frame by frame (:func:`frame_states`) under ``gated`` equal
    ``base``'s bit for bit, and under ``ungated`` (the change without its gate) differ somewhere, so the check can
    fail."""
    a, b = frame_states(base, inter), frame_states(gated, inter)
    assert len(a) == len(b) > 10
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    u = frame_states(ungated, inter)
    assert any(not np.array_equal(x, y) for x, y in zip(a, u))


def foot_lock_keyword(cfg, inter, keyword: str):  # noqa: ANN001, ANN201 (SimConfig, Interaction, FootLockConfig)
    """Run a ground-truth episode of ``inter`` on Stubby under ``cfg`` and record, per :meth:`FootLock.apply` call, the
    truth of its keyword argument ``keyword`` (``False`` when not passed): (the calls' values, the foot lock's config
    as the simulator ran it, after its gates)."""
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.simulator import Simulator

    seen: list[bool] = []
    config = []

    def hook(s, r, e) -> None:  # noqa: ANN001
        fl = s._footlock
        if getattr(fl, "_probe", False):
            return
        config.append(fl.config)
        orig = fl.apply

        def apply(*a, **k):  # noqa: ANN002, ANN003, ANN202
            seen.append(bool(k.get(keyword, False)))
            return orig(*a, **k)
        fl.apply, fl._probe = apply, True
    run_episode(Simulator("ours", inter.label, cfg), GroundTruthSource(), inter, on_frame=hook)
    return seen, config[0]


def spy_ik_leans(monkeypatch: pytest.MonkeyPatch) -> list[float]:
    """Record the ``lean`` every :meth:`RobotIK.solve` call gets (0 where none is passed), in order."""
    from socialaff_sim.retarget.ik import RobotIK

    leans: list[float] = []
    orig_solve = RobotIK.solve

    def spy(self, *a, **kw):  # noqa: ANN001, ANN002, ANN003
        leans.append(kw.get("lean", 0.0))
        return orig_solve(self, *a, **kw)

    monkeypatch.setattr(RobotIK, "solve", spy)
    return leans


def spy_harness_decide(record):  # noqa: ANN001, ANN201 (Callable[[tuple, dict], None] -> the on_frame hook)
    """An ``on_frame`` hook for :func:`~socialaff_sim.sim.episode.run_episode` that wraps the standing controller's
    ``HarnessRelease.decide`` once per episode and calls ``record(args, kwargs)`` before each of its decisions."""
    def hook(s, r, e) -> None:  # noqa: ANN001
        h = s._stage.stepper.balance.harness
        if getattr(h, "_probe", False):
            return
        orig = h.decide

        def decide(*a, **k):  # noqa: ANN002, ANN003, ANN202
            record(a, k)
            return orig(*a, **k)
        h.decide, h._probe = decide, True
    return hook


def shared_robot(*parts: str) -> Path:
    """Path under ../shared/robots (the Unitree MJCF models); skips the test with a reason when it is absent."""
    path = SHARED_ROBOTS.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"robot models not available at {path} (the Unitree MJCFs live in ../shared/robots beside the "
                    "project; the project does not ship them)")
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


@pytest.fixture(scope="session")
def shake8():  # noqa: ANN201 (Dataset, imported lazily)
    """Eight synthetic shake_hands instances (seed 0), shared by the synthesis tests."""
    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset

    return generate_dataset(0, SyntheticConfig(interactions=("shake_hands",), instances_per_interaction=8))


@pytest.fixture(scope="session")
def shake1_npz(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with one synthetic shake_hands recording (seed 0) in the project's npz format, for CLI tests."""
    from socialaff_sim.data import save_dataset
    from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset

    folder = tmp_path_factory.mktemp("npz")
    save_dataset(generate_dataset(seed=0, config=SyntheticConfig(interactions=("shake_hands",), instances_per_interaction=1)), folder)
    return folder


@pytest.fixture(scope="session")
def shake8_model(shake8):  # noqa: ANN001, ANN201
    """A model fitted on the first six of :func:`shake8` with 3 MCMC iterations (seed 0)."""
    from socialaff_sim.learning.config import LearningConfig
    from socialaff_sim.learning import SocialAffordanceModel

    return SocialAffordanceModel(learning=LearningConfig(iterations=3)).fit(list(shake8)[:6], rng=np.random.default_rng(0))


@pytest.fixture(scope="session")
def primitive_method(shake8):  # noqa: ANN001, ANN201 (AffordanceMethod, imported lazily)
    """The default ``full`` method with the interaction primitive's families in its blend, fitted on the first four of
    :func:`shake8` with 1 MCMC iteration (seed 0): the reactor's whole path, for the reactor's speed tests (read-only:
    a test that changes it works on a copy)."""
    from socialaff_sim.inference.methods import AffordanceMethod
    from socialaff_sim.inference.switching import PRIMITIVE_FAMILIES, SwitchingConfig
    from socialaff_sim.learning.config import LearningConfig

    cfg = SwitchingConfig(families=PRIMITIVE_FAMILIES, cross_fit=1, inner_folds=2)
    return AffordanceMethod("full", learning=LearningConfig(iterations=1), reaction=cfg).fit(list(shake8)[:4], rng=np.random.default_rng(0))


def _scene_digest(scene) -> str:  # noqa: ANN001 (Scene)
    """SHA-256 of a scene's compiled model (``mj_saveModel``'s bytes) and of every array of the Scene."""
    import hashlib

    import mujoco

    blob = np.zeros(mujoco.mj_sizeModel(scene.model), dtype=np.uint8)
    mujoco.mj_saveModel(scene.model, None, blob)
    h = hashlib.sha256(blob.tobytes())
    for f in dataclasses.fields(scene):
        value = getattr(scene, f.name)
        if isinstance(value, np.ndarray):
            h.update(f.name.encode() + value.tobytes())
    return h.hexdigest()


@pytest.fixture(scope="session")
def scene():  # noqa: ANN201 (Scene, imported lazily)
    """Stubby's physics scene (``ours``, the kinect_v2 layout, the compliant harness at τ = 0.02 s, no object), shared
    read-only by the balance, stance and arm tests (a module that needs another scene defines its own ``scene``).
    At the end of the session it must be as built: a test that changed its model or arrays fails here."""
    from socialaff_sim.data.skeletons import get_layout
    from socialaff_sim.retarget.robot import load_robot
    from socialaff_sim.sim.scene import build_scene

    built = build_scene(load_robot("ours"), get_layout("kinect_v2"), harness_time_constant=0.02)
    digest = _scene_digest(built)
    yield built
    assert _scene_digest(built) == digest, "a test changed the shared scene (tests/conftest.py: scene is read-only)"


def labelled_partitions(B: int, S: int, *, distinct: bool, unique: bool):  # noqa: ANN201 (Iterator)
    """Every parse of B cut-point intervals: (points, labels) with points 0 = p_0 < … < p_K = B, for brute force."""
    import itertools

    for k in range(B):
        for cuts in itertools.combinations(range(1, B), k):
            pts = [0, *cuts, B]
            for labels in itertools.product(range(S), repeat=len(pts) - 1):
                if distinct and S > 1 and any(a == b for a, b in zip(labels, labels[1:])):
                    continue
                if unique and len(set(labels)) < len(labels):
                    continue
                yield pts, labels


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


def swap_sides(inter, agents):  # noqa: ANN001, ANN201 (Interaction -> Interaction)
    """The instance with every left_*/right_* joint of each agent in ``agents`` exchanged, by name (positions kept)."""
    names = list(inter.joint_names)
    order = np.array([names.index("right_" + n[5:]) if n.startswith("left_") else
                      names.index("left_" + n[6:]) if n.startswith("right_") else i for i, n in enumerate(names)])
    joints, valid = inter.joints.copy(), np.array(inter.valid, copy=True)
    for a in agents:
        joints[:, a], valid[:, a] = inter.joints[:, a][:, order], np.asarray(inter.valid)[:, a][:, order]
    return inter.replace(joints=joints, valid=valid)


def planted_feet_error(sim, inter) -> float:  # noqa: ANN001 (Simulator, Interaction)
    """Median over the frames where both feet stand (foot lock) of the larger horizontal distance (m) between a
    physical ankle frame and its foot's planted point, over a ground-truth episode of ``inter`` on ``sim``."""
    from socialaff_sim.retarget.sources import GroundTruthSource
    from socialaff_sim.sim.episode import run_episode
    from socialaff_sim.sim.stage import key_frames

    err: list[float] = []

    def frame(s, r, _) -> None:  # noqa: ANN001
        fl = s._footlock
        if r is None or not all(fl.standing):
            return
        phys = key_frames(s.scene, s.data)[3:5]
        err.append(max(float(np.linalg.norm(phys[k, :2] - fl.planted[k][:2])) for k in (0, 1)))

    run_episode(sim, GroundTruthSource(), inter, on_frame=frame)
    return float(np.median(err))


FOOT_HOME = (0.08, 0.08)
"""The foot lock's unit tests: the two ankles' heights at home (m)."""
FOOT_ANKLES = np.array([[0.0, 0.1, 0.08], [0.0, -0.1, 0.08]])
"""The foot lock's unit tests: the two ankle targets (2, 3) (world, m) the feet are planted at."""


def planted_lock(config: FootLockConfig, physical: bool = True) -> FootLock:
    """A foot lock of ``config`` with both feet planted at :data:`FOOT_ANKLES` (the physical ankles there too,
    unless ``physical`` is ``False``)."""
    lock = FootLock(FOOT_HOME, config)
    lock.apply(FOOT_ANKLES, physical=FOOT_ANKLES if physical else None)
    assert lock.standing == (True, True)
    return lock
