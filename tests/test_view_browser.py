"""`zentf view --web` as a user sees it: r2d2 live, the web viewer in a real headless Chromium, the
screenshot checked: one 3D view (not two copies of the scene), the robot drawn and framed."""
from __future__ import annotations

import io
import os
import shutil
import sys
import time

import pytest

from conftest import REPO, free_port

pytest.importorskip("rerun", reason="rerun-sdk (zentf[view]) not installed")
Image = pytest.importorskip("PIL.Image")

ZENTF = [sys.executable, "-m", "zentf.cli"]
DATA = REPO / "tests" / "data" / "urdf"
R2D2 = DATA / "urdf_tutorial" / "urdf" / "07-physics.urdf"
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"
#: Rerun's top bar + view title, and its time panel (px): not the scene
TOP, BOTTOM = 60, 40


@pytest.fixture
def gl_browser():
    """Headless Chromium that draws WebGL in software (Rerun's viewer needs it)."""
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    if not (shutil.which(CHROMIUM) and shutil.which(CHROMEDRIVER)):
        if os.environ.get("CI"):
            pytest.fail("chromium and chromium-driver are missing in CI (.ci/run installs them)")
        pytest.skip("chromium and chromium-driver are not installed (apt-get install chromium chromium-driver)")
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-background-networking", "--disable-component-update",
                "--no-first-run", "--disable-sync", "--disable-dev-shm-usage", "--enable-unsafe-swiftshader",
                "--use-angle=swiftshader", "--ignore-gpu-blocklist", "--window-size=1000,700", "--hide-scrollbars"):
        opts.add_argument(arg)
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    driver.set_page_load_timeout(60)
    try:
        yield driver
    finally:
        driver.quit()


def robot_columns(image) -> tuple[list[tuple[int, int]], tuple[int, int, int, int] | None]:
    """(runs of image columns holding r2d2's body blue (0, 0, 0.8), bounding box of it) of a screenshot,
    between the viewer's top bar and its time panel."""
    rgb = image.convert("RGB")
    w, h = rgb.size
    px = rgb.load()
    cols, box = [], None
    for x in range(0, w, 2):
        hit = [y for y in range(TOP, h - BOTTOM, 2) if (lambda p: p[2] > 100 and p[0] < 30 and p[1] < 30)(px[x, y])]
        if hit:
            cols.append(x)
            lo, hi = min(hit), max(hit)
            box = (x, lo, x, hi) if box is None else (min(box[0], x), min(box[1], lo), max(box[2], x), max(box[3], hi))
    runs: list[tuple[int, int]] = []
    for x in cols:
        if runs and x - runs[-1][1] <= 24:  # gaps of a few pixels inside one drawing
            runs[-1] = (runs[-1][0], x)
        else:
            runs.append((x, x))
    return runs, box


def test_view_web_shows_r2d2_in_one_framed_3d_view(spawn, zenoh_env, gl_browser, tmp_path):
    from selenium.common.exceptions import TimeoutException

    env = {**zenoh_env, "ZENTF_PACKAGE_PATH": str(DATA)}
    spawn.python("-m", "nodes.robot_state_publisher", str(R2D2), env=env).wait_for_line("publishing robot", 60)
    spawn.python("-m", "nodes.joint_state_publisher", str(R2D2), env=env).wait_for_line("publishing joint_states", 60)
    web, grpc = free_port(), free_port()
    view = spawn([*ZENTF, "view", "--web", "--web-port", str(web), "--grpc-port", str(grpc), "--rate", "5"], env=env)
    url = view.wait_for_line(r"web viewer: (http://\S+)", 60).group(1)
    gl_browser.get(url)
    deadline = time.monotonic() + 120  # the wasm viewer loads, then software GL draws: slow on a busy machine
    shot = None
    while time.monotonic() < deadline:
        time.sleep(2)
        try:
            shot = Image.open(io.BytesIO(gl_browser.get_screenshot_as_png()))
        except TimeoutException:  # the renderer busy drawing in software on a loaded machine: ask again
            continue
        runs, box = robot_columns(shot)
        if box is not None and box[3] - box[1] > 40:
            break
    assert shot is not None
    shot.save(tmp_path / "view.png")
    runs, box = robot_columns(shot)
    w, h = shot.size
    assert box is not None, f"no robot pixels after 120 s (screenshot: {tmp_path / 'view.png'}); {view.output()}"
    # one 3D view: the robot is drawn once, not once per panel of an automatic two-view layout
    assert len(runs) == 1, (runs, tmp_path / "view.png")
    # framed: a good part of the view's height, inside the picture (not cut off at the bottom)
    assert box[3] - box[1] > 0.2 * h and box[3] < h - BOTTOM - 4, (box, shot.size, tmp_path / "view.png")
    assert "Traceback" not in view.output()
