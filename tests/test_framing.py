"""The side camera keeps every body in the picture below the caption band (issue 25: "a camera framing both
agents at every moment"): the projection against MuJoCo's own camera, and rendered pixels of a raised robot."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import RenderingUnavailableError
from socialaff_sim.sim.framing import MARGIN, fit_camera, project
from socialaff_sim.sim.render import SceneRenderer, caption_band
from socialaff_sim.sim.simulator import SimConfig, Simulator


def test_projection_matches_mujocos_camera() -> None:
    """ndc from :func:`project` equal those from the GL camera MuJoCo builds for the same free camera."""
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom size='1 1 .1' type='plane'/></worldbody></mujoco>")
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_FREE
    cam.lookat[:] = (0.3, -0.2, 1.1)
    cam.distance, cam.azimuth, cam.elevation = 4.2, 37.0, -12.0
    scn = mujoco.MjvScene(model, maxgeom=10)
    mujoco.mjv_updateScene(model, data, mujoco.MjvOption(), mujoco.MjvPerturb(), cam, mujoco.mjtCatBit.mjCAT_ALL, scn)
    gl = scn.camera[0]
    # scn.camera holds the two stereo eyes (ipd apart); a mono render looks from their midpoint.
    pos = 0.5 * (np.array(scn.camera[0].pos) + np.array(scn.camera[1].pos))
    fwd, up = np.array(gl.forward), np.array(gl.up)
    right = np.cross(fwd, up)
    pts = np.random.default_rng(0).uniform([-1, -1, 0], [1, 1, 2.5], size=(50, 3))
    v = pts - pos
    depth = v @ fwd
    # MuJoCo's frustum at its near plane: [bottom, top] vertically, half-width = top * aspect horizontally.
    aspect = 4.0 / 3.0
    ref_y = (v @ up) / depth * gl.frustum_near / gl.frustum_top
    ref_x = (v @ right) / depth * gl.frustum_near / (gl.frustum_top * aspect)
    ndc = project(pts, np.array(cam.lookat), cam.distance, cam.azimuth, cam.elevation, float(model.vis.global_.fovy), aspect)
    np.testing.assert_allclose(ndc[:, 0], ref_x, atol=1e-5)  # MuJoCo keeps its camera in float32
    np.testing.assert_allclose(ndc[:, 1], ref_y, atol=1e-5)


def test_fit_keeps_spheres_below_the_band_and_is_the_floor_when_they_fit() -> None:
    centres = np.array([[0.0, 0.0, 0.1], [0.0, 0.0, 2.4], [1.5, 0.0, 1.0]])
    radii = np.array([0.1, 0.1, 0.2])
    args = dict(azimuth=90.0, elevation=-12.0, fovy=45.0, aspect=4 / 3, band=0.16)
    lookat, d = fit_camera(centres, radii, np.array([0.75, 0.0]), min_distance=3.4, **args)
    edges = np.concatenate([centres + radii[:, None] * [0, 0, 1], centres - radii[:, None] * [0, 0, 1]])
    ndc = project(edges, lookat, d, args["azimuth"], args["elevation"], args["fovy"], args["aspect"])
    assert ndc[:, 1].max() <= 1 - 2 * 0.16 - MARGIN + 1e-9 and ndc[:, 1].min() >= -1 + MARGIN - 1e-9
    assert np.abs(ndc[:, 0]).max() <= 1 - MARGIN
    assert d > 3.4  # 2.5 m of bodies need more than the floor with a 16 % band
    # the same distance again is not enough once the band grows: a larger one is chosen
    _, d2 = fit_camera(centres, radii, np.array([0.75, 0.0]), min_distance=3.4, **{**args, "band": 0.3})
    assert d2 > d
    # a small scene fits at the floor distance itself
    _, d3 = fit_camera(centres[:1], radii[:1], np.array([0.0, 0.0]), min_distance=3.4, **args)
    assert d3 == 3.4


def test_a_raised_robot_shows_below_the_caption_band() -> None:
    """The robot lifted 1.1 m (its head near 2.4 m, as high as a person's raised hand in a high five): its green
    pixels stay below the three caption lines and off the image's edges."""
    inter = generate_dataset(seed=0, config=SyntheticConfig(interactions=("shake_hands",),
                                                            instances_per_interaction=1))[0].slice(0, 4)
    sim = Simulator("ours", "shake_hands", SimConfig.harness())
    sim.reset(inter)
    sim.data.qpos[sim.scene.robot_qadr[2]] += 1.1
    mujoco.mj_forward(sim.scene.model, sim.data)
    try:
        r = SceneRenderer(sim, 320, 240)
    except RenderingUnavailableError as exc:
        pytest.skip(f"no offscreen OpenGL here: {exc}")
    try:
        rgb = r.render(caption=["one", "two", "three"])
    finally:
        r.close()
    band = caption_band(3, max(12, 240 // 26))
    red, green, blue = (rgb[..., c].astype(int) for c in range(3))
    robot = (green > red + 40) & (green > blue + 40)
    rows = np.flatnonzero(robot.any(axis=1))
    assert robot.sum() > 200
    assert rows.min() > band, (rows.min(), band)  # the head below the caption band
    assert rows.max() < 239 and not robot[:, 0].any() and not robot[:, -1].any()
