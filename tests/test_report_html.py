"""The HTML reports open in a real headless browser (Debian's chromium) without console errors,
and every image and video they reference exists, decodes on disk and decodes in the browser."""

from __future__ import annotations

import base64
import json
import shutil
import subprocess
import tempfile
from collections.abc import Iterator
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import imageio_ffmpeg
import numpy as np
import pytest
from PIL import Image
from selenium import webdriver
from selenium.webdriver.chrome.service import Service

from socialaff_sim.cli.main import main
from socialaff_sim.demo import DemoConfig, run_demo
from socialaff_sim.errors import DataError
from socialaff_sim.evaluation import write_results
from socialaff_sim.report import write_demo_page, write_evaluation_page

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--no-first-run", "--disable-sync")

# Waits for every image and video to load or fail, then reports what the browser decoded.
_PROBE = """
const done = arguments[arguments.length - 1];
const imgs = [...document.images], vids = [...document.querySelectorAll('video')];
const settle = (el, ok, events) => new Promise(r => { if (ok()) { r(); return; }
  for (const e of events) el.addEventListener(e, r, {once: true}); });
Promise.all([
  ...imgs.map(i => settle(i, () => i.complete, ['load', 'error'])),
  ...vids.map(v => settle(v, () => v.readyState >= 2 || v.error, ['loadeddata', 'error'])),
]).then(() => done({
  title: document.title,
  images: imgs.map(i => ({src: i.getAttribute('src'), width: i.naturalWidth})),
  videos: vids.map(v => ({src: v.getAttribute('src'), width: v.videoWidth, ready: v.readyState,
                          error: v.error ? v.error.code : null, duration: v.duration})),
}));
"""


class _Refs(HTMLParser):
    """Every src/href/poster the page references."""

    def __init__(self) -> None:
        super().__init__()
        self.images: list[str] = []
        self.videos: list[str] = []
        self.links: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = {k: v or "" for k, v in attrs}
        if tag == "img":
            self.images.append(a["src"])
        elif tag in ("video", "source") and a.get("src"):
            self.videos.append(a["src"])
        if a.get("poster"):
            self.images.append(a["poster"])
        if tag in ("a", "link") and a.get("href") and not a["href"].startswith(("#", "data:")):
            self.links.append(a["href"])


def check_files(page: Path) -> _Refs:
    """Every referenced file is beside the page and decodes; nothing is fetched from elsewhere."""
    refs = _Refs()
    refs.feed(page.read_text(encoding="utf-8"))
    for ref in refs.images + refs.videos + refs.links:
        assert "://" not in ref and not ref.startswith("/"), f"{page.name} references {ref!r}: not self-contained"
        assert (page.parent / ref).is_file(), f"{page.name} references {ref!r}, which does not exist"
    for ref in refs.images:
        with Image.open(page.parent / ref) as im:
            im.load()
            assert min(im.size) > 10
    for ref in refs.videos:
        frames = _video_frames(page.parent / ref)
        assert frames > 1, f"{ref}: {frames} frames decoded"
    return refs


def _video_frames(path: Path) -> int:
    """Frames of a video that decode to a non-uniform picture: ffmpeg (imageio-ffmpeg's binary) decodes every
    frame, scaled to 32 × 24 grey pixels. (subprocess.run closes its pipes; imageio's frame reader leaves them
    open when the video ends, which warnings-as-errors reports.)"""
    out = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-v", "error", "-i", str(path), "-vf", "scale=32:24",
         "-f", "rawvideo", "-pix_fmt", "gray", "-"], capture_output=True, check=True,
    )
    assert out.stderr == b"", out.stderr[-500:]  # decoding errors
    frames = np.frombuffer(out.stdout, np.uint8).reshape(-1, 24 * 32)
    return int((frames.std(axis=1) > 0).sum())


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium chromium-driver)")
    assert CHROMEDRIVER is not None, "chromium is installed but chromedriver is not: apt-get install chromium-driver"
    profile = tempfile.mkdtemp(prefix="socialaff_chromium_")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in (*FLAGS, f"--user-data-dir={profile}", "--window-size=1280,900"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
    # Local files always end in load or error, so the probe finishes; the limit only bounds a broken browser.
    driver.set_script_timeout(3600)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)


def open_in_browser(driver: Any, page: Path) -> dict[str, Any]:
    """Load the page, wait for its media, and return what decoded; fails on any console error."""
    driver.get_log("browser")  # drop what an earlier page logged
    driver.get(page.resolve().as_uri())
    state = driver.execute_async_script(_PROBE)
    errors = [e for e in driver.get_log("browser") if e["level"] in ("SEVERE", "ERROR", "WARNING")]
    assert errors == [], errors
    for img in state["images"]:
        assert img["width"] > 0, f"{img['src']} did not decode in the browser"
    for vid in state["videos"]:
        assert vid["error"] is None and vid["ready"] >= 2 and vid["width"] > 0 and vid["duration"] > 0, vid
    return state


def screenshot(driver: Any, path: Path) -> np.ndarray:
    """A full-page PNG of the current page; returns its pixels."""
    shot = driver.execute_cdp_cmd("Page.captureScreenshot", {"format": "png", "captureBeyondViewport": True})
    path.write_bytes(base64.b64decode(shot["data"]))
    return np.asarray(Image.open(path).convert("RGB"))


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list, DemoConfig]:
    out = tmp_path_factory.mktemp("demo")
    config = DemoConfig(iterations=2, n_test=1, baselines=("promp",), width=320, height=240, seed=1)
    results = run_demo(out, ["shake_hands"], config)
    return out, results, config


def test_demo_page_in_browser(demo_run, browser, tmp_path: Path) -> None:
    out, results, config = demo_run
    page = write_demo_page(out, results, config)
    refs = check_files(page)
    (r,) = results
    if r.video is None:
        pytest.skip(f"offscreen rendering unavailable: {r.video_note}")
    assert refs.videos == [r.video] and set(refs.images) >= {r.synthesis_png, r.groupings_png, r.contact_sheet}
    state = open_in_browser(browser, page)
    assert state["title"] == "socialaff_sim demo" and len(state["videos"]) == 1
    pixels = screenshot(browser, tmp_path / "demo.png")
    assert pixels.shape[0] > 900 and pixels.std() > 10  # more than one screen, not blank


def test_demo_page_content(demo_run) -> None:
    out, results, config = demo_run
    text = write_demo_page(out, results, config).read_text()
    (r,) = results
    assert f"{r.errors['full']:.3f}" in text and f"{r.errors['promp']:.3f}" in text
    assert "offline upper bound" in text and "pair-disjoint" in text  # protocol and split named
    for goal in r.simulation["subgoals"]:
        assert goal["name"] in text
        assert ("met at" if goal["success"] else "missed") in text
    met = sum(g["success"] for g in r.simulation["subgoals"])
    assert f"<td>{met}/{len(r.simulation['subgoals'])}</td>" in text
    if r.video is not None:  # the video's legend: every colour and all three caption lines explained
        assert "blue spheres are the key-joint targets" in text and "yellow" in text
        assert "now touching" in text and "judged at the end" in text and "outside support" in text
        assert "tilt from the vertical" in text
        # the sheet's captions are legible: the image links to its full size
        assert f'<a href="{r.contact_sheet}"><img src="{r.contact_sheet}"' in text


def _results(**extra: Any) -> dict[str, Any]:
    per = {lab: {"full": {"key_joint_error_m": a, "joint_error_m": a + 0.02, "n_test": 4},
                 "hold": {"key_joint_error_m": b, "joint_error_m": b + 0.03, "n_test": 4}}
           for lab, a, b in (("shake_hands", 0.081, 0.123), ("high_five", 0.142, 0.097))}
    return {
        "dataset": "synthetic",
        "per_interaction": per,
        "average": {"full": {"key_joint_error_m": 0.1115, "joint_error_m": 0.1315},
                    "hold": {"key_joint_error_m": 0.110, "joint_error_m": 0.140}},
        "seconds": {"full": 12.5, "hold": 0.4},
        "settings": {"n_folds": 4, "n_observed": 10, "seed": 0, "methods": ["full", "hold"]},
        **extra,
    }


def test_evaluation_page_names_protocol_and_split(tmp_path: Path) -> None:
    paired = {"reference": "hold", "confidence": 0.95, "n_resamples": 1000, "differences": {
        "key_joint_error_m": {"full": {"mean_m": 0.0015, "low_m": -0.012, "high_m": 0.014, "n_instances": 8,
                                       "verdict": "within noise"}}}}
    text = write_evaluation_page(tmp_path, _results(protocol="causal", split="actor-disjoint", preset="default",
                                                    paired=[paired])).read_text()
    assert "Protocol: causal" in text and "Split: actor-disjoint, 4 folds" in text and "Preset: default" in text
    assert "+0.0015" in text and "[-0.0120" not in text and "-0.0120" in text and "within noise" in text and "minus hold" in text
    # the best of each column is bold: hold on shake_hands and on average, full on high_five
    assert '<td class="num best">0.123</td>' not in text and '<td class="num best">0.081</td>' in text
    assert '<td class="num best">0.097</td>' in text and '<td class="num best">0.110</td>' in text
    missing = write_evaluation_page(tmp_path, _results()).read_text()
    assert "Protocol: not recorded in results.json" in missing and "Paired differences" not in missing


def test_evaluation_page_from_results_json_in_browser(tmp_path: Path, browser) -> None:
    write_results(_results(split="pair-disjoint"), tmp_path)
    page = write_evaluation_page(tmp_path)  # reads results.json
    refs = check_files(page)
    assert refs.images == ["results.png"]
    state = open_in_browser(browser, page)
    assert state["title"] == "Evaluation on synthetic"


def test_evaluation_page_rejects_bad_results(tmp_path: Path) -> None:
    with pytest.raises(DataError, match="results.json: not found"):
        write_evaluation_page(tmp_path)
    (tmp_path / "results.json").write_text("{nope")
    with pytest.raises(DataError, match="not valid JSON"):
        write_evaluation_page(tmp_path)
    (tmp_path / "results.json").write_text(json.dumps([1, 2]))
    with pytest.raises(DataError, match="expected a JSON object"):
        write_evaluation_page(tmp_path)
    assert not (tmp_path / "report.html").exists()


def test_evaluate_cli_writes_the_page(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "eval"
    code = main(["evaluate", "--data", "synthetic", "--interactions", "hand_over", "--methods", "promp",
                 "--folds", "2", "--executor", "serial", "--out", str(out), "--quiet"])
    assert code == 0
    captured = capsys.readouterr()
    assert captured.err == ""  # --quiet: no progress lines
    assert (out / "report.html").is_file() and "report.html" in captured.out
    check_files(out / "report.html")
