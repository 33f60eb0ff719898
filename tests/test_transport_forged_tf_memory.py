"""Memory of a ROS 2-wire listener and of the ros2 bridge under forged TFMessages, in real processes.

A peer on the ROS 2 graph puts big CDR TFMessages whose frame names lack their closing NUL (each message a
new shape), then one valid sentinel transform. Whatever the decoders make of such payloads, nothing of
them may be kept: once the sentinel is through, the victim's RSS is within 50 MB of its idle RSS (the
memory the burst used given back), where a listener used to keep ~12 MB per forged message.
"""
from __future__ import annotations

import sys
import textwrap
import time

import pytest


#: A raw Zenoh session on the ROS 2 graph (ZENTF_* and ROS_DOMAIN_ID from the env): argv = messages, bytes
#: each, "nul" (valid strings) or "forged" (no NUL). Child names repeat (the buffer's frame cap is not what
#: is measured) but each message has its own parent: a new shape every time.
FORGER = textwrap.dedent("""
    import os, struct, sys, time
    import zenoh
    from zentf.core.messages import TFMessage
    from zentf.transport.options import ZenohOptions
    from zentf.transport.wire.profiles import make_profile
    count, size, kind = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
    end = b"\\0" if kind == "nul" else b"!"
    key = make_profile("ros2", os.environ["ROS_DOMAIN_ID"]).data_key("/tf", TFMessage.TYPE_NAME)
    s = ZenohOptions.from_env().open_session()
    pub = s.declare_publisher(key, congestion_control=zenoh.CongestionControl.BLOCK)
    while not pub.matching_status.matching:
        time.sleep(0.01)
    def element(buf, parent, child, sec, x, nul=b"\\0"):
        buf += struct.pack("<iII", sec, 0, len(parent) + 1) + parent + nul
        buf += b"\\0" * ((4 - len(buf)) % 4)     # (alignment counts from the end of the 4-byte header)
        buf += struct.pack("<I", len(child) + 1) + child + b"\\0"
        buf += b"\\0" * ((4 - len(buf)) % 8)
        buf += struct.pack("<7d", x, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    def message(k):
        buf = bytearray(b"\\x00\\x01\\x00\\x00\\x00\\x00\\x00\\x00")
        n = 0
        while len(buf) < size:
            element(buf, b"p%d" % k, b"c%d" % (n % 9000), 100, 1.0, end)
            n += 1
        buf[4:8] = struct.pack("<I", n)
        return bytes(buf)
    gid = b"F" * 16
    print("ready", flush=True)
    for k in range(count):
        pub.put(message(k), attachment=struct.pack("<qqB16s", k + 1, time.time_ns(), 16, gid))
    sentinel = bytearray(b"\\x00\\x01\\x00\\x00\\x01\\x00\\x00\\x00")
    element(sentinel, b"world", b"sentinel", int(time.time()), 7.0)
    pub.put(bytes(sentinel), attachment=struct.pack("<qqB16s", count + 1, time.time_ns(), 16, gid))
    print("sent", flush=True)
    time.sleep(1.0)  # (closing at once can lose the last puts)
""")

#: The zentf side of the bridge: a raw subscriber on 'tf' that says when the sentinel came through.
ZENTF_SIDE = textwrap.dedent("""
    import zenoh
    from zentf.transport.options import ZenohOptions
    s = ZenohOptions.from_env().open_session()
    def on(sample):
        if b"sentinel" in sample.payload.to_bytes():
            print("sentinel", flush=True)
    s.declare_subscriber("tf", on)
    print("ready", flush=True)
    import threading; threading.Event().wait()
""")


def memory_mb(pid: int) -> tuple[float, float]:
    """(RSS, peak RSS) of a process, in MB."""
    fields = {}
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            key, _, value = line.partition(":")
            if key in ("VmRSS", "VmHWM"):
                fields[key] = int(value.split()[0]) / 1024
    return fields["VmRSS"], fields["VmHWM"]


def steady_mb(pid: int, timeout: float = 10.0) -> float:
    """RSS once the process has stopped growing after its start (two readings 0.3 s apart within 1 MB)."""
    last = memory_mb(pid)[0]
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        time.sleep(0.3)
        now = memory_mb(pid)[0]
        if abs(now - last) < 1.0:
            return now
        last = now
    return last


def settled_mb(pid: int, idle: float, limit: float, timeout: float = 10.0) -> float:
    """RSS above idle once it is within ``limit`` (the release after a burst takes a moment), else the last."""
    deadline = time.monotonic() + timeout
    while True:
        above = memory_mb(pid)[0] - idle
        if above <= limit or time.monotonic() > deadline:
            return above
        time.sleep(0.2)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("kind", ["forged", "nul"])
@pytest.mark.parametrize("victim", ["listener", "bridge"])
def test_big_tf_messages_leave_no_memory_behind(spawn, ros2_env, victim: str, kind: str) -> None:
    """30 1.8 MB TFMessages (forged: no NUL; or valid), then a sentinel: the victim has it, and its RSS is
    back within 50 MB of idle (before: a `tf echo --wire ros2` listener kept +349 MB of the forged ones,
    the bridge +68 MB)."""
    env = {**ros2_env, "ZENTF_NAMESPACE": ""}
    if victim == "listener":
        proc = spawn.python("-m", "zentf.cli", "tf", "echo", "--wire", "ros2", "world", "sentinel", "-r", "20", env=env)
        proc.wait_for_line("Waiting for transform", timeout=60)
        done = proc
        done_line = r"Translation: \[7\.000"
    else:
        proc = spawn.python("-m", "zentf.cli", "bridge", "ros2", "--ros2-connect", ros2_env["ZENTF_CONNECT"],
                            env={**env, "ZENTF_WIRE": "zentf"})
        proc.wait_for_line("bridging tf", timeout=60)
        done = spawn.python("-c", ZENTF_SIDE, env={**env, "ZENTF_WIRE": "zentf"})
        done.wait_for_line("^ready", timeout=30)
        done_line = "^sentinel"
    idle = steady_mb(proc.pid)  # the process has settled after its start
    forger = spawn.python("-c", FORGER, "30", "1800000", kind, env=env)
    forger.wait_for_line("^sent", timeout=180)
    done.wait_for_line(done_line, timeout=180)
    above = settled_mb(proc.pid, idle, 50.0)
    peak = memory_mb(proc.pid)[1] - idle
    assert above <= 50.0, f"{victim}: {above:.0f} MB above idle after the forged burst (peak +{peak:.0f} MB)"
    if victim == "listener" and kind == "forged":  # every forged element was named and skipped, none inserted
        assert "malformed transform(s)" in proc.output() and "no closing NUL" in proc.output(), proc.output()[-2000:]
