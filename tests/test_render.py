"""Offscreen rendering (EGL): colours, targets, caption, video and contact sheet; a clear error without GL."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from socialaff_sim.data.synthetic import SyntheticConfig, generate_dataset
from socialaff_sim.errors import RenderingUnavailableError
from socialaff_sim.retarget.sources import GroundTruthSource
from socialaff_sim.sim.episode import run_episode
from socialaff_sim.sim.render import SceneRenderer, draw_caption, gl_context
from socialaff_sim.sim.simulator import SimConfig, Simulator
from socialaff_sim.sim.video import EpisodeRecorder, contact_sheet

pytestmark = pytest.mark.render


@pytest.fixture(scope="module")
def inter():
    data = generate_dataset(seed=0, config=SyntheticConfig(interactions=("shake_hands",), instances_per_interaction=1))
    return data[0].slice(0, 12)


def renderer_or_skip(sim: Simulator, w: int, h: int) -> SceneRenderer:
    try:
        return SceneRenderer(sim, w, h)
    except RenderingUnavailableError as exc:
        pytest.skip(f"no offscreen OpenGL here: {exc}")


def test_missing_backend_says_what_to_install(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MUJOCO_GL", "nonsense")
    with pytest.raises(RenderingUnavailableError, match="apt-get install libegl1 libegl-mesa0 libgl1"):
        gl_context(64, 64)
    monkeypatch.setenv("MUJOCO_GL", "glfw")
    monkeypatch.delenv("DISPLAY", raising=False)
    with pytest.raises(RenderingUnavailableError, match="MUJOCO_GL=egl"):
        gl_context(64, 64)


def test_frame_shows_red_human_green_robot_blue_targets(inter) -> None:
    sim = Simulator("ours", "shake_hands", SimConfig.harness())
    sim.reset(inter)
    r = renderer_or_skip(sim, 320, 240)
    try:
        plain = r.render()
        targets = sim.robot_key_frames() + (0.0, 0.0, 0.35)  # lifted clear of the robot's body
        shown = r.render(targets=targets)
        captioned = r.render(caption=["a caption"])
    finally:
        r.close()
        r.close()  # idempotent
    assert plain.shape == (240, 320, 3) and plain.dtype == np.uint8
    red, green, blue = (plain[..., c].astype(int) for c in range(3))
    assert ((red > green + 60) & (red > blue + 60)).sum() > 200  # the human
    assert ((green > red + 40) & (green > blue + 40)).sum() > 200  # the robot
    b2 = shown[..., 2].astype(int) - np.maximum(shown[..., 0], shown[..., 1]).astype(int)
    b1 = plain[..., 2].astype(int) - np.maximum(plain[..., 0], plain[..., 1]).astype(int)
    assert ((b2 > 80) & (b1 <= 80)).sum() >= 10  # pixels turned blue: the target spheres
    assert captioned[:10].mean() < plain[:10].mean()  # the dark caption band
    with pytest.raises(RenderingUnavailableError, match="closed"):
        r.render()


def test_caption_and_contact_sheet_layout() -> None:
    img = np.full((60, 80, 3), 200, dtype=np.uint8)
    out = draw_caption(img, ["one", "two"], size=12)
    assert out.shape == img.shape and out[:5].mean() < 120 and out[-5:].mean() == 200
    sheet = contact_sheet([img] * 5, cols=4)
    assert sheet.shape == (120, 320, 3)
    assert (sheet[60:, 80:] == 255).all()  # blank cells


def test_video_and_contact_sheet_files(inter, tmp_path: Path) -> None:
    imageio = pytest.importorskip("imageio.v2")
    sim = Simulator("ours", "shake_hands", SimConfig.harness())
    try:
        rec = EpisodeRecorder(sim, tmp_path / "v.mp4", tmp_path / "s.png", width=160, height=128, n_sheet=4)
    except RenderingUnavailableError as exc:
        pytest.skip(f"no offscreen OpenGL here: {exc}")
    with rec:
        run_episode(sim, GroundTruthSource(), inter, on_frame=rec)
    assert rec.n_written == inter.n_frames
    # imageio's ffmpeg reader leaves its subprocess pipes to the garbage collector (a third-party
    # ResourceWarning, an error under -W error); read it back and collect inside an ignore block.
    import gc
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResourceWarning)
        reader = imageio.get_reader(tmp_path / "v.mp4")
        try:
            frames = [reader.get_data(i) for i in range(reader.count_frames())]
        finally:
            reader.close()
            del reader
            gc.collect()
    assert len(frames) == inter.n_frames and frames[0].shape == (128, 160, 3)
    from PIL import Image

    with Image.open(tmp_path / "s.png") as sheet:
        assert sheet.size == (4 * 160, 128)
    assert not list(tmp_path.glob(".*"))  # no temporary files left behind
