"""joint_state_publisher --gui: the slider page, driven by a real headless Chromium (selenium)."""
from __future__ import annotations

import http.client
import json
import math
import shutil
import socket
import struct
import time

import psutil
import pytest

from conftest import REPO

R2D2 = REPO / "tests" / "data" / "urdf" / "urdf_tutorial" / "urdf" / "06-flexible.urdf"
PROBE = str(REPO / "tests" / "tf_lookup_probe.py")
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"


@pytest.fixture
def browser():
    webdriver = pytest.importorskip("selenium.webdriver")
    from selenium.webdriver.chrome.service import Service

    if not (shutil.which(CHROMIUM) and shutil.which(CHROMEDRIVER)):
        pytest.skip("chromium and chromium-driver are not installed (.ci/run installs them)")
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for arg in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                "--disable-component-update", "--no-first-run", "--disable-sync", "--disable-dev-shm-usage"):
        opts.add_argument(arg)
    driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    driver.set_page_load_timeout(60)
    driver.set_script_timeout(60)
    try:
        yield driver
    finally:
        driver.quit()


def _next_value(probe, pair: str, accept, timeout: float = 30.0) -> dict:
    """The first line of ``pair`` from the probe for which ``accept(line)`` holds."""
    while True:
        line = json.loads(probe.wait_for_line(r'^\{"pair"', timeout=timeout).string)
        if line["pair"] == pair and accept(line):
            return line


def _yaw(q: list[float]) -> float:
    x, y, z, w = q
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def _get(url_port: int, path: str, host: str | None = None, method: str = "GET", body: bytes | None = None,
         ctype: str | None = None) -> tuple[int, bytes]:
    conn = http.client.HTTPConnection("127.0.0.1", url_port, timeout=10)
    headers = {"Host": host or f"127.0.0.1:{url_port}"}
    if ctype:
        headers["Content-Type"] = ctype
    conn.request(method, path, body=body, headers=headers)
    r = conn.getresponse()
    data = r.read()
    conn.close()
    return r.status, data


def test_moving_a_slider_in_the_browser_moves_the_frame_a_listener_sees(spawn, browser) -> None:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys
    from selenium.webdriver.support.ui import WebDriverWait

    rsp = spawn.python("-m", "nodes.robot_state_publisher", str(R2D2), "-p", "publish_frequency:=1000")
    rsp.wait_for_line(r"publishing robot 'visual'", timeout=30)
    jsp = spawn.python("-m", "nodes.joint_state_publisher", str(R2D2), "--gui", "--no-browser")
    url = jsp.wait_for_line(r"sliders: (http://127\.0\.0\.1:\d+/)", timeout=30).group(1)
    probe = spawn.python(PROBE, "base_link:head", "base_link:gripper_pole")
    first = _next_value(probe, "base_link:head", lambda ln: True)
    assert abs(_yaw(first["q"])) < 1e-12  # start value 0

    browser.get(url)
    wait = WebDriverWait(browser, 20)
    wait.until(lambda d: len(d.find_elements(By.CSS_SELECTOR, "input[type=range]")) == 8)
    names = [e.get_attribute("id") for e in browser.find_elements(By.CSS_SELECTOR, "input[type=range]")]
    assert names[4] == "slider-gripper_extension" and names[-1] == "slider-head_swivel"
    ext = browser.find_element(By.ID, "slider-gripper_extension")
    assert float(ext.get_attribute("min")) == -0.38 and float(ext.get_attribute("max")) == 0.0
    head = browser.find_element(By.ID, "slider-head_swivel")
    assert float(head.get_attribute("min")) == pytest.approx(-math.pi)  # continuous: ±π
    assert float(head.get_attribute("max")) == pytest.approx(math.pi)

    # the user moves the head slider with the keyboard: Home = its lower end (-π), then right arrows
    head.click()
    head.send_keys(Keys.HOME)
    line = _next_value(probe, "base_link:head", lambda ln: abs(abs(_yaw(ln["q"])) - math.pi) < 1e-6)
    assert line["t"] == pytest.approx([0, 0, 0.3])
    wait.until(lambda d: d.find_element(By.ID, "value-head_swivel").get_attribute("value") == "-3.14")
    head.send_keys(Keys.ARROW_RIGHT * 100)  # one WebDriver command, 100 key presses
    expected = -math.pi + 100 * (2 * math.pi / 1000)
    _next_value(probe, "base_link:head", lambda ln: abs(_yaw(ln["q"]) - expected) < 1e-6)

    # the gripper slides out when its slider goes to the lower end
    ext.click()
    ext.send_keys(Keys.HOME)
    line = _next_value(probe, "base_link:gripper_pole", lambda ln: abs(ln["t"][0] - (0.19 - 0.38)) < 1e-9)
    assert line["t"] == pytest.approx([0.19 - 0.38, 0, 0.2])

    # Center: everything back to the start values, shown on the page
    browser.find_element(By.ID, "center").click()
    _next_value(probe, "base_link:head", lambda ln: abs(_yaw(ln["q"])) < 1e-12)
    wait.until(lambda d: d.find_element(By.ID, "value-head_swivel").get_attribute("value") == "0.00")

    # Randomize: every joint somewhere within its limits; the page shows the publisher's values (live)
    browser.find_element(By.ID, "randomize").click()
    moved = _next_value(probe, "base_link:head", lambda ln: abs(_yaw(ln["q"])) > 1e-9)
    port = int(url.rsplit(":", 1)[1].strip("/"))
    status, body = _get(port, "/state")
    state = json.loads(body)
    values = {j["name"]: j for j in state["joints"]}
    assert all(j["lower"] <= j["value"] <= j["upper"] for j in values.values())
    assert _yaw(moved["q"]) == pytest.approx(values["head_swivel"]["value"], abs=1e-9)
    wait.until(lambda d: all(
        d.find_element(By.ID, f"value-{n}").get_attribute("value") == f"{j['value']:.2f}" for n, j in values.items()))
    assert "Traceback" not in jsp.output()


def test_the_gui_server_refuses_foreign_hosts_and_non_json_posts(spawn) -> None:
    jsp = spawn.python("-m", "nodes.joint_state_publisher", str(R2D2), "--gui", "--no-browser")
    url = jsp.wait_for_line(r"sliders: (http://127\.0\.0\.1:\d+/)", timeout=30).group(1)
    port = int(url.rsplit(":", 1)[1].strip("/"))
    status, body = _get(port, "/")
    assert status == 200 and b"Randomize" in body
    assert _get(port, "/state", host="evil.example:80")[0] == 403          # DNS rebinding
    assert _get(port, "/set", method="POST", body=b"head_swivel=1", ctype="application/x-www-form-urlencoded")[0] == 415
    status, body = _get(port, "/set", method="POST", body=b'{"nope": 1}', ctype="application/json")
    assert status == 400 and b"'nope' is not a movable" in body
    status, body = _get(port, "/set", method="POST", body=b'{"head_swivel": "x"}', ctype="application/json")
    assert status == 400 and b"expected a finite number" in body
    status, body = _get(port, "/set", method="POST", body=b'{"head_swivel": 99}', ctype="application/json")
    assert status == 200
    assert {j["name"]: j["value"] for j in json.loads(body)["joints"]}["head_swivel"] == pytest.approx(math.pi)


def _raw(port: int, data: bytes, *, reset: bool) -> None:
    """Send ``data`` and close at once: with a reset (RST, as a client killed mid-request) or a plain close."""
    s = socket.create_connection(("127.0.0.1", port), timeout=5)
    try:
        s.sendall(data)
        if reset:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
    finally:
        s.close()


def test_the_slider_page_answers_bad_values_in_one_line_and_shrugs_off_hostile_clients(spawn) -> None:
    from zentf.tools.joint_state_gui import MAX_CONNECTIONS, READ_TIMEOUT

    jsp = spawn.python("-m", "nodes.joint_state_publisher", str(R2D2), "--gui", "--no-browser")
    url = jsp.wait_for_line(r"sliders: (http://127\.0\.0\.1:\d+/)", timeout=30).group(1)
    port = int(url.rsplit(":", 1)[1].strip("/"))
    # a value no float holds, and JSON nested past the parser's depth: 400 with the reason in one line
    status, body = _get(port, "/set", method="POST", body=b'{"head_swivel": 1' + b"0" * 400 + b"}",
                        ctype="application/json")
    assert status == 400, body
    error = json.loads(body)["error"]
    assert "head_swivel" in error and "finite number" in error and "\n" not in error and len(error) < 200, error
    status, body = _get(port, "/set", method="POST", body=b"[" * 60000, ctype="application/json")
    assert status == 400, body
    # 150 clients that vanish mid-request (a cut body, a reset while the answer is written): no traceback
    head = f"POST /set HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Type: application/json\r\n"
    for i in range(50):
        _raw(port, (head + "Content-Length: 1000\r\n\r\n{\"head").encode(), reset=i % 2 == 0)
        _raw(port, f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n\r\n".encode(), reset=True)
        _raw(port, f"GET /state HTTP/1.1\r\nHost: 127.0.0".encode(), reset=True)
    # half-open connections: each is served by a thread only up to MAX_CONNECTIONS, and for READ_TIMEOUT s
    proc = psutil.Process(jsp.pid)
    idle = [socket.create_connection(("127.0.0.1", port), timeout=10) for _ in range(MAX_CONNECTIONS + 24)]
    try:
        t0 = time.monotonic()
        for s in idle:  # every one is closed by the server: refused at once (503) or after the timeout
            s.recv(4096)
        took = time.monotonic() - t0
        assert took < READ_TIMEOUT + 5, took
        assert proc.num_threads() < 40 + MAX_CONNECTIONS
    finally:
        for s in idle:
            s.close()
    assert _get(port, "/state")[0] == 200  # and it still serves
    status, _ = _get(port, "/set", method="POST", body=b'{"head_swivel": 0.5}', ctype="application/json")
    assert status == 200
    jsp.stop()
    out = jsp.output()
    for word in ("Traceback", "ConnectionResetError", "BrokenPipeError", "OverflowError", "RecursionError"):
        assert word not in out, out[-3000:]
