"""scripts/hero_image.py: the README's hero image is the chosen frames of a demo video, side by side."""

from __future__ import annotations

import gc
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import load_script
from PIL import Image

hero = load_script("hero_image")


def _video(path: Path, n: int) -> None:
    """A 64 × 48 video whose frame i is a flat grey of level 10 + 20 i (distinct after compression)."""
    imageio = pytest.importorskip("imageio.v2")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResourceWarning)
        writer = imageio.get_writer(path, fps=10, codec="libx264", quality=9, macro_block_size=16,
                                    ffmpeg_log_level="error")
        for i in range(n):
            writer.append_data(np.full((48, 64, 3), 10 + 20 * i, np.uint8))
        writer.close()
        gc.collect()


def test_frames_side_by_side_in_the_order_asked(tmp_path: Path) -> None:
    _video(tmp_path / "v.mp4", 8)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResourceWarning)
        out = hero.write_hero(tmp_path / "v.mp4", [6, 2], tmp_path / "hero.png")
        gc.collect()
    with Image.open(out) as im:
        rgb = np.asarray(im.convert("RGB")).astype(float)
    assert rgb.shape == (48, 128, 3)
    assert abs(rgb[:, :64].mean() - (10 + 20 * 6)) < 4 and abs(rgb[:, 64:].mean() - (10 + 20 * 2)) < 4
    assert not list(tmp_path.glob(".*"))  # no temporary file left


def test_a_frame_past_the_end_is_named_and_nothing_is_written(tmp_path: Path) -> None:
    _video(tmp_path / "v.mp4", 5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ResourceWarning)
        with pytest.raises(ValueError, match="no frame 9 .the video has 5 frames"):
            hero.write_hero(tmp_path / "v.mp4", [1, 9], tmp_path / "hero.png")
        gc.collect()
    assert not (tmp_path / "hero.png").exists()
