"""Terminal injection (issue 10, point 7, CLI half): frame ids, topics and node names that carry ESC,
CR or LF are printed escaped by every CLI listing, so a hostile name cannot clear the screen,
recolour it or forge output lines."""
from __future__ import annotations

import pytest
from cli_helpers import zentf

from zentf.cli.format import printable

EVIL = "evil\x1b[2J\rFORGED\nline\u202e"
SHOWN = "evil\\x1b[2J\\rFORGED\\nline\\u202e"

INJECTOR = r'''
import sys, time, json, zenoh
from zentf.transport.wire import codec as wire
from zentf.core.messages import TFMessage
ep, ns, evil = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
cfg = zenoh.Config()
cfg.insert_json5("mode", '"client"')
cfg.insert_json5("connect/endpoints", json.dumps([ep]))
cfg.insert_json5("scouting/multicast/enabled", "false")
s = zenoh.open(cfg)
ns_chunk = "%" + ns
tokens = [s.liveliness().declare_token(f"@zentf/node/{ns_chunk}/{evil}"),
          s.liveliness().declare_token(f"@zentf/pub/{ns_chunk}/{evil}/%tf2_msgs%msg%TFMessage/{ns}/tf"),
          s.liveliness().declare_token(f"@zentf/pub/{ns_chunk}/{evil}/%geometry_msgs%msg%Point/{ns}/{evil}")]
msg = TFMessage.from_dict({"transforms": [{
    "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "base"}, "child_frame_id": evil,
    "transform": {"translation": {"x": 1.0}, "rotation": {"w": 1.0}}}]})
enc = wire.encoding_for(TFMessage.TYPE_NAME)
print("injecting", flush=True)
while True:
    msg.transforms[0].header.stamp = type(msg.transforms[0].header.stamp).from_sec(time.time())
    s.put(f"{ns}/tf", wire.encode(msg), encoding=enc, attachment=f"/{ns}/{evil}".encode())
    time.sleep(0.05)
'''


def test_printable_escapes_controls_and_keeps_the_rest():
    assert printable(EVIL) == SHOWN
    assert printable("base_link/été") == "base_link/été"
    assert printable("a\tb\x07\x7f\x9b") == "a\\tb\\x07\\x7f\\x9b"


@pytest.fixture
def injector(spawn, zenoh_router, test_namespace):
    import json
    import sys

    p = spawn([sys.executable, "-c", INJECTOR, zenoh_router, test_namespace, json.dumps(EVIL)])
    p.wait_for_line("injecting", 30)
    return p


@pytest.mark.parametrize("args", [
    ["tf", "monitor", "--duration", "2"],
    ["tf", "monitor", "base", EVIL, "--duration", "2"],
    ["tf", "frames", "--print", "--wait", "2", "-o", "{tmp}/frames.gv"],
    ["node", "list"],
    ["node", "info", f"/{{ns}}/{EVIL}"],
    ["topic", "list", "-v"],
    ["topic", "info", f"{{ns}}/{EVIL}"],
    ["graph"],
    ["graph", "--dot"],
    ["tf", "echo", EVIL, "nowhere", "--timeout", "1"],
], ids=["monitor", "monitor-pair", "frames", "node-list", "node-info", "topic-list", "topic-info", "graph",
        "graph-dot", "echo-error"])
def test_listings_print_hostile_names_escaped(injector, zenoh_env, test_namespace, tmp_path, args):
    argv = [a.replace("{tmp}", str(tmp_path)).replace("{ns}", test_namespace) for a in args]
    proc = zentf(argv, zenoh_env, timeout=60)
    out = proc.stdout + proc.stderr
    for raw in ("\x1b", "\r", "\u202e"):
        assert raw not in out, (argv, out)
    assert not any(line.startswith("line") for line in out.splitlines()), out  # no forged line
    assert SHOWN in out or SHOWN.replace("\\", "\\\\") in out, (argv, out)


def test_bag_info_prints_hostile_names_escaped(tmp_path, zenoh_env):
    """`zentf bag info` lists a bag's topics, types and tf frames: a bag from anyone cannot drive the terminal."""
    from zentf.transport.wire import codec as wire
    from zentf.core.messages import TFMessage
    from zentf.tools.bag import BagWriter

    msg = TFMessage.from_dict({"transforms": [{
        "header": {"stamp": {"sec": 1, "nanosec": 0}, "frame_id": "base"}, "child_frame_id": EVIL,
        "transform": {"translation": {"x": 1.0}, "rotation": {"w": 1.0}}}]})
    path = tmp_path / "evil.mcap"
    with BagWriter(path) as w:
        w.write("tf", wire.encode(msg), str(wire.encoding_for(TFMessage.TYPE_NAME)), log_time=1_000_000_000)
        w.write(f"topic_{EVIL}", b"\x80", f"{wire.ENCODING};pkg/msg/{EVIL}", log_time=2_000_000_000)
    proc = zentf(["bag", "info", str(path)], zenoh_env)
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout + proc.stderr
    for raw in ("\x1b", "\r", "\u202e"):
        assert raw not in out, out
    assert not any(line.startswith("line") for line in out.splitlines()), out  # no forged line
    assert f"base -> {SHOWN}" in out, out          # a tf frame
    assert f"topic_{SHOWN}" in out, out             # a topic
    assert f"pkg/msg/{SHOWN}" in out, out           # a type
