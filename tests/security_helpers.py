"""Shared pieces of the security tests: throw-away certificates and per-client working directories.

The shipped configs (configs/zenoh/router-tls.json5, router-acl.json5, client-tls.json5) name their
certificates relative to the working directory (``certs/ca.pem``, ``certs/client.pem``...), so each
process runs in a directory of its own whose ``certs/`` holds that machine's files - as on a real robot.
"""
from __future__ import annotations

import json
import shutil
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pytest

from conftest import REPO, Proc, free_port

CLIENTS = ("robot-a", "base-b", "intruder", "operator")
ROUTER_TLS = REPO / "configs/zenoh/router-tls.json5"
ROUTER_ACL = REPO / "configs/zenoh/router-acl.json5"
CLIENT_TLS = REPO / "configs/zenoh/client-tls.json5"


def make_certs(out: Path, sans: Sequence[str] = ()) -> Path:
    """scripts/make_certs.sh OUT --client robot-a --client base-b --client intruder [--san ...]."""
    if shutil.which("openssl") is None:
        pytest.skip("openssl not installed (scripts/make_certs.sh needs it)")
    proc = subprocess.run(["bash", str(REPO / "scripts/make_certs.sh"), str(out),
                           *[a for c in CLIENTS for a in ("--client", c)], *[a for s in sans for a in ("--san", s)]],
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return out


def machine_dir(base: Path, certs: Path, name: str, *, key_of: str | None = None, ca: str = "ca") -> Path:
    """``base/name/certs/`` with ca.pem (the CA this machine trusts) and client.pem/.key (``key_of``'s)."""
    d = base / name
    (d / "certs").mkdir(parents=True, exist_ok=True)
    shutil.copy(certs / f"{ca}.pem", d / "certs/ca.pem")
    who = key_of or name
    if who == "router":
        for ext in ("pem", "key"):
            shutil.copy(certs / f"router.{ext}", d / f"certs/router.{ext}")
    else:
        shutil.copy(certs / f"{who}.pem", d / "certs/client.pem")
        shutil.copy(certs / f"{who}.key", d / "certs/client.key")
    return d


def start_tls_router(spawn: Any, cwd: Path, config: Path) -> tuple[Proc, str]:
    """``zentf router --config CONFIG --listen tls/127.0.0.1:PORT`` run in ``cwd`` (which holds certs/)."""
    for _ in range(3):
        ep = f"tls/127.0.0.1:{free_port()}"
        router = spawn([sys.executable, "-m", "zentf.cli", "router", "--config", str(config), "--listen", ep],
                       cwd=cwd)
        try:
            router.wait_for_line(r"listening on tls/", 30)
            return router, ep
        except AssertionError:
            router.stop()
    raise RuntimeError("could not start a TLS router")


def client_config(machine: Path, endpoint: str, timeout_ms: int = 0) -> Any:
    """A zenoh.Config from the shipped client-tls.json5 with this machine's files as absolute paths."""
    import zenoh

    cfg = zenoh.Config.from_file(str(CLIENT_TLS))
    cfg.insert_json5("connect/endpoints", json.dumps([endpoint]))
    cfg.insert_json5("connect/timeout_ms", json.dumps({"client": timeout_ms}))
    cfg.insert_json5("connect/exit_on_failure", json.dumps({"client": True}))
    for key, file in (("root_ca_certificate", "ca.pem"), ("connect_certificate", "client.pem"),
                      ("connect_private_key", "client.key")):
        cfg.insert_json5(f"transport/link/tls/{key}", json.dumps(str(machine / "certs" / file)))
    return cfg


def client_flags(endpoint: str, namespace: str) -> list[str]:
    return ["--zenoh-config", str(CLIENT_TLS), "--connect", endpoint, "--namespace", namespace]
