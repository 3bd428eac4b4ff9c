"""What makes the environment fast must not change what it does: bitwise-equal episodes per seed, a scene
compiled once per robot and task, resets that replay cached arrays instead of compiling or solving IK."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import socialaff_sim.sim.stage_build as stage_build_module
from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.environment import SocialAffordanceEnv
from socialaff_sim.retarget.ik import RobotIK
from socialaff_sim.sim.frame_targets import fill_targets

FRAMES = 12


@pytest.fixture(scope="module")
def data():
    """Three instances each of an interaction without and one with an object."""
    return generate_dataset(seed=3, config=SyntheticConfig(interactions=("shake_hands", "hand_over"),
                                                           instances_per_interaction=3))


def make(data, **kw) -> SocialAffordanceEnv:
    kw.setdefault("max_frames", FRAMES)
    return SocialAffordanceEnv(data=data, **kw)


def run(env: SocialAffordanceEnv, seeds: list[int], n_steps: int, action_seed: int) -> list[tuple]:
    """(observation, reward, terminated, reward terms) of ``n_steps`` steps, resetting with the next of ``seeds``
    whenever an episode ends; actions uniform in the action space from their own Generator."""
    rng = np.random.default_rng(action_seed)
    low, high = env.action_space.low, env.action_space.high
    seeds = list(seeds)
    obs, _ = env.reset(seed=seeds.pop(0))
    out: list[tuple] = [(obs, 0.0, False, {})]
    for _ in range(n_steps):
        obs, r, term, trunc, info = env.step(rng.uniform(low, high).astype(np.float32))
        out.append((obs, r, term, {k: v for k, v in info.items() if k.startswith("reward_")}))
        if term or trunc or info["frame"] >= FRAMES - 1:
            obs, _ = env.reset(seed=seeds.pop(0))
            out.append((obs, 0.0, False, {}))
    return out


def assert_same(a: list[tuple], b: list[tuple]) -> None:
    assert len(a) == len(b)
    for (oa, ra, ta, ia), (ob, rb, tb, ib) in zip(a, b, strict=True):
        assert ra == rb and ta == tb and ia == ib  # exact: bitwise equal floats
        for k in oa:
            np.testing.assert_array_equal(oa[k], ob[k], err_msg=k)


@pytest.mark.parametrize("mode", ["targets", "residual"])
def test_same_seed_same_steps_in_two_fresh_envs(data, mode):
    seeds = list(range(100, 140))
    a = run(make(data, action_mode=mode), seeds, 50, action_seed=7)
    b = run(make(data, action_mode=mode), seeds, 50, action_seed=7)
    assert_same(a, b)
    # and the comparison can fail: other actions give other observations
    c = run(make(data, action_mode=mode), seeds, 50, action_seed=8)
    assert any(not np.array_equal(x[0]["joint_pos"], y[0]["joint_pos"]) for x, y in zip(a, c, strict=True))


def test_reused_env_replays_an_instance_as_a_fresh_env_plays_it(data):
    """An env that has played other instances (and this one) before, so its reset takes the cached
    placement and settle, steps exactly as a fresh env does."""
    seen = make(data, action_mode="residual")
    index = {}
    for s in range(40):  # every instance, some twice
        info = seen.reset(seed=s)[1]
        index.setdefault(info["instance"], s)
        for _ in range(3):
            if seen.step(seen.action_space.sample())[2]:
                break
    assert len(index) == len(seen.pool.instances)
    for instance, seed in index.items():
        hot = run(seen, [seed] * 10, 15, action_seed=seed)
        cold = run(make(data, action_mode="residual"), [seed] * 10, 15, action_seed=seed)
        assert_same(hot, cold)
        assert hot[0][0]["interaction"].argmax() == seen.pool.labels.index(seen.pool.instances[
            seen.pool.indices(instance=instance)[0]].label)


def test_scene_compiled_once_per_robot_and_task(data, monkeypatch):
    calls = []
    original = stage_build_module.compile_scenes

    def counting(*args, **kwargs):
        calls.append(args[0].name)
        return original(*args, **kwargs)

    monkeypatch.setattr(stage_build_module, "compile_scenes", counting)
    env = make(data, action_mode="residual")
    for s in range(12):
        env.reset(seed=s)
        env.step(np.zeros((5, 3), np.float32))
    tasks = {x.label for x in env.pool.instances}
    assert len(tasks) == 2 and len(calls) == len(tasks)  # one stage per task (both have one skeleton layout)
    before = len(calls)
    for s in range(12, 30):
        env.reset(seed=s)
    assert len(calls) == before


def test_second_reset_of_an_instance_solves_no_ik(data, monkeypatch):
    solves = []
    original = RobotIK.solve

    def counting(self, *args, **kwargs):
        solves.append(1)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(RobotIK, "solve", counting)
    env = make(data, action_mode="residual")
    first = env.unwrapped.pool.instances[1].instance_id
    other = env.unwrapped.pool.instances[4].instance_id
    solves.clear()
    env.reset(seed=0, options={"instance": first})
    cold = len(solves)
    assert cold >= env.simulator.config.settle_iterations  # the settle IK ran
    env.step(np.zeros((5, 3), np.float32))
    env.reset(options={"instance": other})
    solves.clear()
    env.reset(options={"instance": first})
    assert solves == []  # placement and settle replayed from the cache
    env.step(np.zeros((5, 3), np.float32))
    assert len(solves) == 1  # stepping still solves, once per frame


def test_settle_not_straight_after_a_reset_is_solved_and_not_cached(data):
    """The settle cache holds only for the IK state straight after a reset (home pose, clear collision
    memory); a later settle starts elsewhere, so it is solved and not remembered."""
    env = make(data, action_mode="residual")
    env.reset(seed=0)  # settles on the first proposal (remembered)
    sim = env.simulator
    assert len(sim._placement.settled) == 1
    targets = sim.robot_key_frames() + np.array([0.0, 0.0, 0.05])
    sim.settle(targets)
    assert len(sim._placement.settled) == 1
    assert sim._placement.settled_for(sim.frame_R.to_world(fill_targets(targets, sim.home_key_frames))) is None


def test_make_vec_two_workers_sync_steps_and_resets(data):
    venv = gym.make_vec("socialaff_sim/SocialAffordance-v0", num_envs=2, vectorization_mode="sync",
                        data=data, max_frames=6, action_mode="residual")
    try:
        obs, _ = venv.reset(seed=[0, 1])
        assert obs["joint_pos"].shape[0] == 2
        ends = 0
        for _ in range(80):  # two episodes each (5 frames of at most 7 control steps): automatic resets
            obs, rew, term, trunc, info = venv.step(np.zeros((2, 5, 3), np.float32))
            assert np.isfinite(rew).all() and rew.shape == (2,)
            ends += int(np.sum(term | trunc))
        assert ends >= 2
        obs2, _ = venv.reset(seed=[0, 1])
        first, _ = gym.make_vec("socialaff_sim/SocialAffordance-v0", num_envs=2, vectorization_mode="sync",
                                data=data, max_frames=6, action_mode="residual").reset(seed=[0, 1])
        for k in obs2:
            np.testing.assert_array_equal(obs2[k], first[k], err_msg=k)
    finally:
        venv.close()


def test_make_vec_two_workers_async(data):
    venv = gym.make_vec("socialaff_sim/SocialAffordance-v0", num_envs=2, vectorization_mode="async",
                        data=data, max_frames=5, action_mode="residual")
    try:
        venv.reset(seed=[3, 4])
        for _ in range(6):
            _, rew, term, trunc, _ = venv.step(np.zeros((2, 5, 3), np.float32))
            assert np.isfinite(rew).all()
    finally:
        venv.close()


def _episode(sim, inter, placement_frames):
    """Robot coordinates after each step of a replay of agent 1 with a causal placement."""
    keys = inter.key_joints()[:, 1]
    sim.reset(inter, placement_frames=placement_frames)
    sim.settle(sim.retarget(keys[0], frame=0))
    out = [sim.data.qpos.copy()]
    while not sim.done:
        t = sim.frame + 1
        sim.step(sim.retarget(keys[t], frame=t))
        out.append(np.concatenate([sim.data.qpos, sim.ik_qpos, [sim.scaler.k]]))
    return out


def test_simulator_reset_reuse_with_causal_placement(data):
    """With ``placement_frames`` the scaler's placement moves online during an episode: a second episode
    of the instance on the same simulator must start from the placement of a fresh one."""
    from socialaff_sim.environment.instances import gap_filled
    from socialaff_sim.sim.simulator import SimConfig, Simulator
    from socialaff_sim.sim.tasks import load_task

    inters = [gap_filled(i.slice(0, 14)) for i in data if i.label == "shake_hands"]
    sim = Simulator("ours", load_task("shake_hands"), SimConfig.harness())
    first = _episode(sim, inters[0], 10)
    _episode(sim, inters[1], 10)
    again = _episode(sim, inters[0], 10)
    fresh = _episode(Simulator("ours", load_task("shake_hands"), SimConfig.harness()), inters[0], 10)
    for a, b, c in zip(first, again, fresh, strict=True):
        np.testing.assert_array_equal(a, c)
        np.testing.assert_array_equal(b, c)
    # The placement moves online in an episode (not in these short replays): whatever it reached, the
    # next episode of the instance starts from the placement of its first reset.
    sim.reset(inters[0], placement_frames=10)
    k0 = sim.scaler.k
    sim.scaler.k, sim.scaler._k_goal = k0 - 0.25, k0 - 0.25
    sim.reset(inters[0], placement_frames=10)
    assert sim.scaler.k == k0 and sim.scaler._k_goal == k0


def test_collision_limit_memory_round_trip(data):
    env = make(data, action_mode="residual", interactions="hand_over", max_frames=30)
    env.reset(seed=1)
    limit = env.simulator._stage.ik.collision_limit
    while not np.isfinite(limit._before).any() and env.simulator.frame < 28:
        env.step(np.zeros((5, 3), np.float32))
    limit = env.simulator._stage.ik.collision_limit
    mem = limit.memory()
    assert np.isfinite(mem.before).any()  # pairs were seen
    limit.restore(None)
    assert np.isinf(limit._before).all() and len(limit.last_active) == 0
    limit.restore(mem)
    np.testing.assert_array_equal(limit._before, mem.before)
    np.testing.assert_array_equal(limit.last_active, mem.last_active)
    mem.before[...] = 0.0  # the limit holds its own copy
    assert not (limit._before == 0.0).all()


class _ReferenceMeter:
    """The support figures computed the plain way, step by step (the meter before it batched its work):
    the harness force as Jᵀλ of the weld's rows (``SupportMeter.harness_force``), each contact looked at on
    its own step."""

    def __init__(self, meter) -> None:
        self.m = meter
        self.frames: list[tuple] = []
        self.prev: list = [None, None]
        self._clear()

    def _clear(self) -> None:
        self.out, self.peak, self.pen, self.ratio, self.sat, self.lim, self.tilt, self.n = 0.0, 0.0, 0.0, 0.0, 0, 0, 0.0, 0
        self.slide = [0.0, 0.0]

    def update(self, d) -> None:
        m, sc = self.m, self.m.scene
        v = float(np.linalg.norm(m.harness_force(d))) / m.weight + m.gravcomp_fraction
        self.out += v
        self.peak = max(self.peak, v)
        floor = sc.floor_geom
        for i in range(d.ncon):
            g1, g2 = (int(x) for x in d.contact.geom[i])
            other = g2 if g1 == floor else g1 if g2 == floor else -1
            if other >= 0 and sc.robot_geom[other]:
                self.pen = max(self.pen, -float(d.contact.dist[i]))
        for s, (body, geoms) in enumerate(m._feet):
            touching = False
            for i in range(d.ncon):
                g1, g2 = (int(x) for x in d.contact.geom[i])
                other = g2 if g1 == floor else g1 if g2 == floor else -1
                touching |= other >= 0 and bool(geoms[other]) and d.contact.dist[i] <= 0
            pos = np.array(d.xpos[body, :2])
            if touching and self.prev[s] is not None:
                self.slide[s] += float(np.hypot(*(pos - self.prev[s])))
            self.prev[s] = pos if touching else None
        ratio = np.abs(d.actuator_force[sc.act_ids]) / m._act_limit
        self.ratio = max(self.ratio, float(ratio.max()))
        self.sat += bool(ratio.max() >= 0.99)
        q = d.qpos[m._lim_qadr]
        self.lim += bool(((q - m._lim_range[:, 0] <= 1e-3) | (m._lim_range[:, 1] - q <= 1e-3)).any())
        up = d.xmat[m._torso].reshape(3, 3) @ m._torso_up
        self.tilt = max(self.tilt, float(np.degrees(np.arccos(np.clip(up[2], -1, 1)))))
        self.n += 1

    def end_frame(self) -> None:
        n = max(self.n, 1)
        self.frames.append((self.out / n, self.peak, max(self.slide), self.pen, self.ratio, self.sat / n,
                            self.lim / n, self.tilt))
        self._clear()


def test_support_meter_matches_the_step_by_step_figures(data):
    """The batched support meter gives the figures of a plain per-step computation (to rounding), and the
    same feet-down state, over a hand-over replay with the object, steps and contacts."""
    env = make(data, action_mode="residual", interactions="hand_over", max_frames=30)
    env.reset(seed=2)
    stepper = env.simulator._stage.stepper
    meter = stepper.support
    ref = _ReferenceMeter(meter)
    feet = []

    class Both:
        def update(self, d) -> None:
            meter.update(d)
            ref.update(d)

        def end_frame(self):
            ref.end_frame()
            out = meter.end_frame()
            feet.append((meter.feet_down, tuple(p is not None for p in ref.prev)))
            return out

        def __getattr__(self, name):
            return getattr(meter, name)

    stepper.support = Both()
    try:
        while not env.step(np.zeros((5, 3), np.float32))[2] and env.simulator.frame < 29:
            pass
    finally:
        stepper.support = meter
    got = [(f.outside_mean, f.outside_peak, f.slide, f.penetration, f.torque_ratio, f.saturated, f.at_limit,
            f.tilt_deg) for f in meter.frames]
    assert len(got) == len(ref.frames) >= 20
    np.testing.assert_allclose(np.array(got), np.array(ref.frames), rtol=1e-9, atol=1e-12)
    assert all(a == b for a, b in feet)
    assert any(f[2] > 0 for f in ref.frames) or any(all(x) for x, _ in feet)  # feet on the floor were seen


def test_warm_up_caches_every_instance_and_asks_for_a_reset(data, monkeypatch):
    from socialaff_sim.errors import SimulationError

    env = make(data, action_mode="residual")
    env.warm_up()
    with pytest.raises(SimulationError, match="reset"):
        env.step(np.zeros((5, 3), np.float32))
    solves = []
    original = RobotIK.solve
    monkeypatch.setattr(RobotIK, "solve", lambda self, *a, **k: solves.append(1) or original(self, *a, **k))
    for inter in env.pool.instances:
        env.reset(seed=0, options={"instance": inter.instance_id})
    assert solves == []
    fresh = make(data, action_mode="residual")
    np.testing.assert_array_equal(env.reset(seed=5)[0]["joint_pos"], fresh.reset(seed=5)[0]["joint_pos"])
