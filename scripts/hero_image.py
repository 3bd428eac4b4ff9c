"""The README's hero image from a demo run: chosen frames of one of its videos, side by side (issue 25).

Decodes the demo's video (imageio-ffmpeg) and writes the frames ``--frames`` next to each other as one PNG, the
caption of each frame as the demo drew it. The README's image is the handshake at frames 23 (the walk-up) and
38 (the hands together)::

    MUJOCO_GL=egl socialaff-sim demo --out demo_out
    python scripts/hero_image.py --video demo_out/shake_hands.mp4 --frames 23 38 --out docs/images/demo_shake_hands.png
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from socialaff_sim._atomic import atomic_path
from socialaff_sim.sim.render import pillow
from socialaff_sim.sim.video import contact_sheet


def read_frames(video: Path, frames: list[int]) -> list[np.ndarray]:
    """The (H, W, 3) uint8 frames ``frames`` of ``video`` in the order asked; a ValueError names a missing one."""
    import imageio.v2 as imageio

    want = set(frames)
    got: dict[int, np.ndarray] = {}
    n = 0
    reader = imageio.get_reader(video)
    try:
        for n, rgb in enumerate(reader, start=1):
            if n - 1 in want:
                got[n - 1] = np.asarray(rgb)
    finally:
        reader.close()
    missing = [f for f in frames if f not in got]
    if missing:
        raise ValueError(f"{video}: no frame {missing[0]} (the video has {n} frames)")
    return [got[f] for f in frames]


def write_hero(video: Path, frames: list[int], out: Path) -> Path:
    """Write ``frames`` of ``video`` side by side to the PNG ``out`` (atomically); returns ``out``."""
    sheet = contact_sheet(read_frames(video, frames), cols=len(frames))
    with atomic_path(out, suffix=".png") as tmp:
        pillow().Image.fromarray(sheet).save(tmp, format="PNG")
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--video", type=Path, required=True, help="a demo video, e.g. demo_out/shake_hands.mp4")
    p.add_argument("--frames", type=int, nargs="+", default=[23, 38], help="frame indices (default 23 38)")
    p.add_argument("--out", type=Path, required=True, help="the PNG to write")
    args = p.parse_args()
    try:
        path = write_hero(args.video, args.frames, args.out)
    except ValueError as exc:
        p.exit(2, f"hero_image: {exc}\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
