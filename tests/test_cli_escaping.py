"""Names from the network or a file never drive the terminal: frame ids, joint, node, topic and type names
and message strings that carry ESC, CR, LF, C1 controls (CSI, NEL) or bidi overrides reach every listing,
log line and output line escaped, so a hostile name cannot clear the screen, recolour it, reorder text or
forge a line. Real processes: an injector on the graph and each program that prints names."""
from __future__ import annotations

import json
import re
import sys
import uuid

import pytest
from cli_helpers import ZENTF, zentf
from conftest import REPO

from zentf.cli.format import printable

EVIL = "evil\x1b[2J\r\n[ERROR] forged\x9b31m\x85\u202e\u2066x"
SHOWN = "evil\\x1b[2J\\r\\n[ERROR] forged\\x9b31m\\x85\\u202e\\u2066x"
#: EVIL in a YAML double-quoted string (topic echo), YAML's own escapes where it has them
YAML_SHOWN = "evil\\e[2J\\r\\n[ERROR] forged\\x9B31m\\N\\u202e\\u2066x"
FORGED = "[ERROR] forged"
#: What may never reach a terminal raw: C0 controls but LF (TAB too), DEL, C1, line/paragraph
#: separators, bidi embeddings, overrides, isolates and marks, zero-width and tag characters.
RAW = re.compile("[\x00-\x09\x0b-\x1f\x7f-\x9f\u061c\u200b-\u200f\u2028-\u202e\u2060-\u2069\ufeff\U000e0000-\U000e007f]")

INJECTOR = r'''
import sys, time, json, zenoh
from zentf.transport.wire import codec as wire
from zentf.core.messages import JointState, String, TFMessage
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

def tf(child, x):
    return TFMessage.from_dict({"transforms": [{
        "header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": "base"}, "child_frame_id": child,
        "transform": {"translation": {"x": x}, "rotation": {"w": 1.0}}}]})

good, nan = tf(evil, 1.0), tf(evil, float("nan"))
joints = JointState.from_dict({"name": [evil], "position": [0.0]})
att = f"/{ns}/{evil}".encode()
print("injecting", flush=True)
while True:
    for msg in (good, nan):
        msg.transforms[0].header.stamp = type(msg.transforms[0].header.stamp).from_sec(time.time())
        s.put(f"{ns}/tf", wire.encode(msg), encoding=wire.encoding_for(TFMessage.TYPE_NAME), attachment=att)
    s.put(f"{ns}/tf", b"\x80", encoding=f"{wire.ENCODING};pkg/msg/{evil}", attachment=att)  # a type nobody knows
    s.put(f"{ns}/joint_states", wire.encode(joints), encoding=wire.encoding_for(JointState.TYPE_NAME))
    s.put(f"{ns}/chatter", wire.encode(String(evil)), encoding=wire.encoding_for(String.TYPE_NAME))
    s.put(f"{ns}/raw", b"\x01\x02", encoding=f"text/plain;{evil}")
    s.put(f"{ns}/{evil}", b"\xc1", encoding=wire.encoding_for("visualization_msgs/msg/Marker"))
    time.sleep(0.05)
'''

#: A URDF whose robot, link and joint names carry what XML allows of it (no ESC: XML 1.0 forbids it).
EVIL_URDF = """<robot name="evil&#13;&#10;[ERROR] forged&#x9b;31m&#x85;&#x202e;">
  <link name="base"/>
  <link name="arm&#x202e;&#10;[ERROR] forged"/>
  <joint name="j&#13;&#10;[ERROR] forged&#x9b;" type="revolute">
    <parent link="base"/><child link="arm&#x202e;&#10;[ERROR] forged"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>
"""
URDF_SHOWN = "evil\\r\\n[ERROR] forged\\x9b31m\\x85\\u202e"


def assert_escaped(out: str, shown: str = SHOWN) -> None:
    """No raw control character, no forged line, and the name itself is there (escaped)."""
    raw = RAW.search(out)
    assert raw is None, (f"raw {raw.group()!r} in output", out)
    assert not any(line.lstrip().startswith(FORGED) for line in out.splitlines()), out
    assert shown in out or shown.replace("\\", "\\\\") in out, out


def test_printable_escapes_controls_and_keeps_the_rest():
    assert printable(EVIL) == SHOWN
    assert printable("base_link/été") == "base_link/été"
    assert printable("a\tb\x07\x7f\x9b") == "a\\tb\\x07\\x7f\\x9b"
    assert printable("zero\u200bwidth\ufeff tag\U000e0041") == "zero\\u200bwidth\\ufeff tag\\U000e0041"
    assert printable(printable(EVIL)) == SHOWN  # escaping twice changes nothing
    assert RAW.search(printable("".join(map(chr, range(0x3000))))) is None


@pytest.fixture
def injector(spawn, zenoh_router, test_namespace):
    p = spawn([sys.executable, "-c", INJECTOR, zenoh_router, test_namespace, json.dumps(EVIL)])
    p.wait_for_line("injecting", 30)
    return p


@pytest.mark.parametrize("args", [
    ["tf", "monitor", "--duration", "2"],
    ["tf", "monitor", "base", EVIL, "--duration", "2"],
    ["tf", "frames", "--print", "--wait", "2", "-o", "{tmp}/frames.gv"],
    ["tf", "echo", "base", EVIL, "--count", "2"],
    ["tf", "echo", EVIL, "nowhere", "--timeout", "1"],
    ["node", "list"],
    ["node", "info", f"/{{ns}}/{EVIL}"],
    ["topic", "list", "-v"],
    ["topic", "info", f"{{ns}}/{EVIL}"],
    ["topic", "echo", "chatter", "--count", "1"],
    ["topic", "echo", "raw", "--count", "1"],
    ["graph"],
    ["graph", "--dot"],
], ids=["monitor", "monitor-pair", "frames", "echo-listener-warnings", "echo-error", "node-list", "node-info",
        "topic-list", "topic-info", "topic-echo", "topic-echo-raw", "graph", "graph-dot"])
def test_cli_prints_hostile_names_escaped(injector, zenoh_env, test_namespace, tmp_path, args):
    argv = [a.replace("{tmp}", str(tmp_path)).replace("{ns}", test_namespace) for a in args]
    proc = zentf(argv, zenoh_env, timeout=60)
    assert "Traceback" not in proc.stderr, proc.stderr
    assert_escaped(proc.stdout + proc.stderr, YAML_SHOWN if args[:3] == ["topic", "echo", "chatter"] else SHOWN)


def test_listener_warnings_name_the_frame_escaped(injector, zenoh_env):
    """tf echo's listener logs the NaN transform and the message of an unknown type, both naming EVIL."""
    proc = zentf(["tf", "echo", "base", EVIL, "--count", "2"], zenoh_env, timeout=60)
    assert "TF_NAN_INPUT" in proc.stderr and f'child_frame_id "{SHOWN}"' in proc.stderr, proc.stderr
    assert f"wrong type pkg/msg/{SHOWN}" in proc.stderr, proc.stderr
    assert_escaped(proc.stdout + proc.stderr)


def _program_output(spawn, argv: list[str], wait_for: str, env: dict[str, str] | None = None) -> str:
    """Run a long-lived program until it prints a line matching ``wait_for``, stop it, return its output."""
    p = spawn([*ZENTF, *argv], env=env)
    p.wait_for_line(wait_for, 60)
    p.stop(timeout=10)
    return p.output()


def test_robot_state_publisher_logs_an_unknown_joint_escaped(injector, spawn):
    out = _program_output(spawn, ["run", "robot_state_publisher", str(REPO / "configs/robots/my_robot.urdf")],
                          "unknown joint")
    assert f"unknown joint '{SHOWN}'" in out, out
    assert_escaped(out)


def test_joint_state_publisher_prints_the_model_names_escaped(spawn, zenoh_env, tmp_path):
    urdf = tmp_path / "evil.urdf"
    urdf.write_text(EVIL_URDF)
    out = _program_output(spawn, ["run", "joint_state_publisher", str(urdf)], "publishing joint_states")
    assert f"robot '{URDF_SHOWN}'" in out, out
    assert_escaped(out, URDF_SHOWN)
    # the model's names in an error line too (a joint naming a link that does not exist)
    urdf.write_text(EVIL_URDF.replace('<child link="arm', '<child link="nowhere'))
    proc = zentf(["run", "joint_state_publisher", str(urdf)], zenoh_env)
    assert proc.returncode == 2, proc.stderr
    assert_escaped(proc.stdout + proc.stderr, "nowhere\\u202e\\n[ERROR] forged")


def test_bridge_logs_an_unrelayable_type_escaped(injector, zenoh_router, zenoh_env):
    proc = zentf(["bridge", "ros2", "--ros2-connect", zenoh_router, "--ros2-mode", "client",
                  "--domain", str(1 + uuid.uuid4().int % 200), "--duration", "3"], zenoh_env, timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert f"type pkg/msg/{SHOWN}" in proc.stderr, proc.stderr
    assert_escaped(proc.stdout + proc.stderr)


def test_view_log_lines_name_frames_and_keys_escaped(injector, zenoh_env, test_namespace, tmp_path):
    pytest.importorskip("rerun", reason="rerun-sdk (zentf[view]) not installed")
    proc = zentf(["view", "--save", str(tmp_path / "v.rrd"), "--duration", "3", "--fixed-frame", "nowhere"],
                 zenoh_env, timeout=90)
    assert proc.returncode == 0, proc.stderr
    assert "fixed frame 'nowhere' is not in the tf tree" in proc.stderr, proc.stderr
    assert f"dropped bad visualization_msgs/msg/Marker on '{test_namespace}/{SHOWN}'" in proc.stderr, proc.stderr
    assert_escaped(proc.stdout + proc.stderr)


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
    assert_escaped(out)
    assert f"base -> {SHOWN}" in out, out          # a tf frame
    assert f"topic_{SHOWN}" in out, out             # a topic
    assert f"pkg/msg/{SHOWN}" in out, out           # a type
