"""TLS and mutual TLS through the shipped configs (configs/zenoh/router-tls.json5, client-tls.json5).

Certificates come from scripts/make_certs.sh (a throw-away CA; ``rogue`` is signed by another CA).
Each process runs in its own directory whose certs/ holds that machine's files, as on a real robot.
"""
from __future__ import annotations

import os
import sys
from pathlib import Path

import pytest

from conftest import REPO
from netns_fixtures import next_state
from security_helpers import (ROUTER_TLS, client_config, client_flags, machine_dir, make_certs,
                              start_tls_router)

pytestmark = pytest.mark.timeout(120)


@pytest.fixture(scope="module")
def certs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_certs(tmp_path_factory.mktemp("certs"))


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env.update(PYTHONUNBUFFERED="1", PYTHONPATH=os.pathsep.join(
        p for p in (str(REPO), os.environ.get("PYTHONPATH", "")) if p))
    return env


def _opens(cfg: object) -> bool:
    import zenoh

    try:
        zenoh.open(cfg).close()
        return True
    except Exception:
        return False


def test_wrong_certificates_are_refused(certs: Path, tmp_path: Path, spawn) -> None:
    router_dir = machine_dir(tmp_path, certs, "router")
    _, ep = start_tls_router(spawn, router_dir, ROUTER_TLS)
    good = machine_dir(tmp_path, certs, "robot-a")
    rogue = machine_dir(tmp_path, certs, "rogue", key_of="rogue")              # right CA, cert from another CA
    blind = machine_dir(tmp_path, certs, "blind", key_of="robot-a", ca="rogue-ca")  # trusts the wrong CA
    assert _opens(client_config(good, ep)), "an authorized client must connect (control)"
    assert not _opens(client_config(rogue, ep)), "a client certificate from another CA was accepted"
    assert not _opens(client_config(blind, ep)), "a client accepted a router certificate from an unknown CA"
    no_cert = client_config(good, ep)
    no_cert.insert_json5("transport/link/tls/connect_certificate", '""')
    no_cert.insert_json5("transport/link/tls/connect_private_key", '""')
    no_cert.insert_json5("transport/link/tls/enable_mtls", "false")
    assert not _opens(no_cert), "mutual TLS: a client without a certificate was accepted"
    plain = client_config(good, ep.replace("tls/", "tcp/"))
    plain.insert_json5("transport/link/protocols", '["tcp"]')
    assert not _opens(plain), "the TLS router answered plain TCP"


def test_server_only_tls_lets_a_client_without_certificate_in(certs: Path, tmp_path: Path, spawn) -> None:
    router_dir = machine_dir(tmp_path, certs, "router")
    config = router_dir / "router-tls-server-only.json5"
    text = ROUTER_TLS.read_text()
    assert "enable_mtls: true" in text
    config.write_text(text.replace("enable_mtls: true", "enable_mtls: false"))
    _, ep = start_tls_router(spawn, router_dir, config)
    anon = client_config(machine_dir(tmp_path, certs, "anon", key_of="robot-a"), ep)
    anon.insert_json5("transport/link/tls/enable_mtls", "false")
    assert _opens(anon)
    blind = client_config(machine_dir(tmp_path, certs, "blind", key_of="robot-a", ca="rogue-ca"), ep)
    blind.insert_json5("transport/link/tls/enable_mtls", "false")
    assert not _opens(blind), "a client accepted a router certificate from an unknown CA"


def test_mtls_transforms_flow_and_a_rogue_publisher_never_gets_in(certs: Path, tmp_path: Path, spawn,
                                                                    test_namespace: str) -> None:
    router_dir = machine_dir(tmp_path, certs, "router")
    _, ep = start_tls_router(spawn, router_dir, ROUTER_TLS)
    flags = client_flags(ep, test_namespace)
    py = sys.executable
    # the rogue machine keeps retrying (client-tls.json5 waits for the router) but is never let in
    spawn([py, "-m", "nodes.static_transform_publisher", *flags, "--name", "rogue_static", "--frame-id", "world",
           "--child-frame-id", "evil"], env=_env(), cwd=machine_dir(tmp_path, certs, "rogue", key_of="rogue"))
    spawn([py, "-m", "nodes.static_transform_publisher", *flags, "--frame-id", "world", "--child-frame-id",
           "tower", "--x", "3"], env=_env(), cwd=machine_dir(tmp_path, certs, "robot-a"))
    spawn([py, "-m", "nodes.frames_publisher", *flags], env=_env(), cwd=machine_dir(tmp_path, certs, "robot-a"))
    watcher = spawn([py, str(REPO / "tests/net_probe.py"), *flags, "--static", "world:tower"], env=_env(),
                    cwd=machine_dir(tmp_path, certs, "base-b"))
    state = next_state(watcher, lambda s: s["static"] and s["av1_ns"], 30)
    state = next_state(watcher, lambda s: s["checked"] >= state["checked"] + 10, 10)
    assert "evil" not in state["frames"] and state["bad"] == 0
