"""Render the docs' robot picture: r2d2 (urdf_tutorial 07-physics) in the pose of its RViz screenshot.

    python scripts/render_robot_picture.py [--out docs/urdf_r2d2.png] [--keep-rrd r2d2.rrd]

What it runs, all on a private loopback router and stopped at the end: robot_state_publisher,
joint_state_publisher with flexible.png's slider values (gripper_extension -0.26, head_swivel -0.82),
and `zentf view --save` (the .rrd). The .rrd is then shown by Rerun's own web viewer (`rerun
--serve-web`, with a blueprint: one 3D view, RViz's camera of that screenshot, frame axes and labels
hidden) in headless Chromium (software rendering), and the 3D view is cropped into the PNG.
Needs rerun-sdk, selenium, chromium + chromedriver, trimesh + pycollada for the gripper's .dae meshes.
"""
from __future__ import annotations

import argparse
import math
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
R2D2 = REPO / "tests" / "data" / "urdf" / "urdf_tutorial" / "urdf" / "07-physics.urdf"
POSE = {"gripper_extension": -0.26, "head_swivel": -0.82}
# RViz's orbit camera of flexible.png: yaw 5.5, pitch 0.33, distance 1.7, focal point (0, 0, 0)
YAW, PITCH, DISTANCE = 5.5, 0.33, 1.7
ZOOM = 0.8  # Rerun's field of view is wider than RViz's: come closer to frame the robot alike


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(proc: subprocess.Popen, text: str, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    assert proc.stdout is not None
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            raise RuntimeError(f"{proc.args} exited before printing {text!r}")
        if text in line:
            return
    raise RuntimeError(f"{proc.args} did not print {text!r} within {timeout} s")


def record(rrd: Path, procs: list[subprocess.Popen]) -> None:
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    env = {**os.environ, "PYTHONPATH": str(REPO), "PYTHONUNBUFFERED": "1", "ZENTF_CONNECT": endpoint,
           "ZENTF_MODE": "client", "ZENTF_NO_MULTICAST": "1", "ZENTF_NAMESPACE": "r2d2_picture",
           "ZENTF_PACKAGE_PATH": str(R2D2.parents[2])}

    def start(*args: str) -> subprocess.Popen:
        p = subprocess.Popen([sys.executable, *args], env=env, cwd=REPO, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True)
        procs.append(p)
        return p

    router = start("-m", "zentf.transport.router", "--listen", endpoint, "--no-multicast")
    wait_for(router, "listening on")
    wait_for(start("-m", "nodes.robot_state_publisher", str(R2D2)), "publishing robot")
    wait_for(start("-m", "nodes.joint_state_publisher", str(R2D2),
                   *[a for n, v in POSE.items() for a in ("--set", f"{n}={v}")]), "publishing joint_states")
    view = start("-m", "zentf.cli", "view", "--fixed-frame", "base_link", "--save", str(rrd), "--duration", "3")
    out, _ = view.communicate(timeout=60)
    if view.returncode != 0:
        raise RuntimeError(f"zentf view failed:\n{out}")
    sys.stderr.write(out)


def blueprint(path: Path, frames: list[str]) -> None:
    import rerun as rr
    import rerun.blueprint as rrb

    d = DISTANCE * ZOOM
    eye = [d * math.cos(YAW) * math.cos(PITCH), d * math.sin(YAW) * math.cos(PITCH), d * math.sin(PITCH)]
    # RViz's TF display was off in that screenshot: no frame axes, no names
    quiet = [rr.TransformAxes3D.from_fields(axis_length=0.0), rr.Points3D.from_fields(radii=0.0, show_labels=False)]
    overrides = {f"/tf/{rr.escape_entity_path_part(f)}": quiet for f in frames}
    view = rrb.Spatial3DView(origin="/tf", contents=["+ /tf/**"], name="r2d2", overrides=overrides,
                             background=[48, 48, 48], line_grid=rrb.LineGrid3D(visible=True, spacing=0.5),
                             eye_controls=rrb.EyeControls3D(position=eye, look_target=[0, 0, 0], eye_up=[0, 0, 1]))
    rrb.Blueprint(view, collapse_panels=True).save("zentf_view", str(path))


def screenshot(rrd: Path, rbl: Path, png: Path) -> None:
    import rerun_cli
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    exe = os.path.join(os.path.dirname(rerun_cli.__file__), "rerun")
    web, grpc = free_port(), free_port()
    server = subprocess.Popen([exe, "--serve-web", str(rrd), str(rbl), "--web-viewer-port", str(web), "--port", str(grpc)],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, stdin=subprocess.DEVNULL)
    opts = webdriver.ChromeOptions()
    opts.binary_location = "/usr/bin/chromium"
    for a in ("--headless", "--no-sandbox", "--disable-background-networking", "--disable-component-update",
              "--no-first-run", "--disable-sync", "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
              "--ignore-gpu-blocklist", "--window-size=1000,800", "--hide-scrollbars"):
        opts.add_argument(a)
    driver = None
    try:
        deadline = time.monotonic() + 20
        while True:
            try:
                socket.create_connection(("127.0.0.1", web), timeout=0.5).close()
                break
            except OSError:
                if time.monotonic() > deadline:
                    raise RuntimeError("rerun --serve-web did not start")
                time.sleep(0.2)
        driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=opts)
        url = f"http://127.0.0.1:{web}/?url=rerun%2Bhttp%3A%2F%2F127.0.0.1%3A{grpc}%2Fproxy"
        driver.get(url)
        time.sleep(25)  # the wasm viewer loads, the software rasterizer draws a few frames
        driver.save_screenshot(str(png))
    finally:
        if driver is not None:
            driver.quit()
        server.terminate()
        server.wait(10)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(REPO / "docs" / "urdf_r2d2.png"))
    parser.add_argument("--keep-rrd", default=None)
    args = parser.parse_args()
    from zentf.urdf import load_urdf

    frames = list(load_urdf(R2D2).links)
    with tempfile.TemporaryDirectory() as tmp:
        rrd = Path(args.keep_rrd) if args.keep_rrd else Path(tmp) / "r2d2.rrd"
        procs: list[subprocess.Popen] = []
        try:
            record(rrd, procs)
        finally:
            for p in reversed(procs):
                if p.poll() is None:
                    p.terminate()
                    try:
                        p.wait(5)
                    except subprocess.TimeoutExpired:
                        p.kill()
        rbl = Path(tmp) / "view.rbl"
        blueprint(rbl, frames)
        raw = Path(tmp) / "raw.png"
        screenshot(rrd, rbl, raw)
        from PIL import Image

        image = Image.open(raw).convert("RGB")
        # keep the 3D view: drop Rerun's top bar + view title (64 px) and the time panel (40 px)
        image.crop((0, 64, image.width, image.height - 40)).save(args.out, optimize=True)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
