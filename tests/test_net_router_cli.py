"""`zentf router [--listen EP] [--config FILE]`: starts from the shipped configs, refuses bad ones in one line."""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO, free_port

pytestmark = pytest.mark.timeout(60)


def _zentf(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    return subprocess.run([sys.executable, "-m", "zentf.cli", *args], capture_output=True, text=True, timeout=30,
                          env=env, cwd=cwd)


@pytest.mark.parametrize("name", ["peer-lan", "client", "router", "router-tls", "client-tls", "router-acl"])
def test_shipped_zenoh_configs_parse(name: str) -> None:
    import zenoh

    from zentf.transport.options import ZenohOptions

    path = REPO / "configs/zenoh" / f"{name}.json5"
    cfg = zenoh.Config.from_file(str(path))
    assert json.loads(cfg.get_json("timestamping/enabled")) is True  # latched tf_static needs it
    if "tls" not in name and "acl" not in name:
        ZenohOptions(config_file=str(path)).config()  # no certificate files needed


@pytest.mark.parametrize("content, expected", [
    ('{ mode: "router", listen: { endpoints: [', r"line 1, column \d+: expected"),
    ('{ mode: "router", bogus: 1 }', r"line 1, column \d+: unknown field `bogus`"),
    ('{ transport: { link: { tls: { root_ca_certificate: "certs/nope.pem" } } } }',
     r"transport/link/tls/root_ca_certificate: file not found: certs/nope.pem"),
])
def test_bad_config_file_is_one_line(tmp_path: Path, content: str, expected: str) -> None:
    f = tmp_path / "bad.json5"
    f.write_text(content)
    proc = _zentf("router", "--config", str(f), cwd=tmp_path)
    assert proc.returncode != 0
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert str(f) in lines[0]
    assert re.search(expected, lines[0]), lines[0]


def test_missing_config_and_bad_endpoint_are_refused() -> None:
    proc = _zentf("router", "--config", "/nonexistent/router.json5")
    assert proc.returncode != 0 and "Zenoh config file not found: /nonexistent/router.json5" in proc.stderr
    proc = _zentf("router", "--listen", "nowhere")
    assert proc.returncode != 0 and "bad endpoint 'nowhere'" in proc.stderr


def test_config_file_endpoints_are_used_and_listen_overrides_them(tmp_path: Path, spawn) -> None:
    port = free_port()
    cfg = tmp_path / "r.json5"
    cfg.write_text((REPO / "configs/zenoh/router.json5").read_text().replace("tcp/0.0.0.0:7447",
                                                                            f"tcp/127.0.0.1:{port}"))
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    r1 = spawn([sys.executable, "-m", "zentf.cli", "router", "--config", str(cfg)], env=env)
    r1.wait_for_line(rf"listening on tcp/127\.0\.0\.1:{port}$", 30)
    other = free_port()
    r2 = spawn([sys.executable, "-m", "zentf.cli", "router", "--config", str(cfg), "--listen",
                f"tcp/127.0.0.1:{other}"], env=env)
    r2.wait_for_line(rf"listening on tcp/127\.0\.0\.1:{other}$", 30)
    # both really listen: a client of each connects (client mode fails fast without its router)
    from zentf.transport.options import ZenohOptions

    for p in (port, other):
        ZenohOptions(connect=[f"tcp/127.0.0.1:{p}"], mode="client", no_multicast=True).open_session().close()
    r1.stop()
    assert r1.returncode == 0


@pytest.mark.parametrize("name", ["router", "machine_a", "machine_b"])
def test_split_launch_files_resolve(name: str) -> None:
    proc = _zentf("launch", str(REPO / "configs/split" / f"{name}.yaml"), "--print")
    assert proc.returncode == 0, proc.stderr
    assert "zenoh" in proc.stdout


def test_split_router_launch_file_runs_a_router(tmp_path: Path, spawn) -> None:
    port = free_port()
    cfg = tmp_path / "r.json5"
    cfg.write_text((REPO / "configs/zenoh/router.json5").read_text().replace("tcp/0.0.0.0:7447",
                                                                            f"tcp/127.0.0.1:{port}"))
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    launcher = spawn([sys.executable, "-m", "zentf.cli", "launch", str(REPO / "configs/split/router.yaml"),
                      f"zenoh_config:={cfg}"], env=env)
    launcher.wait_for_line(rf"\[router\] zentf router \S+ listening on tcp/127\.0\.0\.1:{port}", 30)
    from zentf.transport.options import ZenohOptions

    ZenohOptions(connect=[f"tcp/127.0.0.1:{port}"], mode="client", no_multicast=True).open_session().close()
