"""Records tests/data/tf_doctor_staged.mcap: a small tf graph with staged problems, for docs/cli.md's
`zentf tf doctor --bag` and `zentf tf why --bag` examples (a recording gives the same output every run,
a live graph does not).

    python tests/tf_doctor_bag_record.py tests/data/tf_doctor_staged.mcap

On a graph of its own (a free ZENTF_LOCAL_PORT, root namespace): a chain world -> a1 -> b1 -> c1 -> d1 -> e1
(/healthy1 sends every edge but b1 -> c1, which /stale1 sends until it goes silent), two publishers of
``payload`` (/dup_a, /dup_b), a publisher stamping 2.5 s behind its clock (/laggard, ``gimbal``), a static
``camera`` that /cam_on_tf also sends on tf, and /doomed's ``beacon``, killed half-way.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _send(parent: str, child: str, rate: float = 20.0, **kw: object) -> dict:
    return {"parent": parent, "child": child, "rate": rate, **kw}


def _start(cmd: list[str], env: dict[str, str], ready: str) -> subprocess.Popen:
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    assert proc.stdout is not None
    for line in proc.stdout:
        if ready in line:
            threading.Thread(target=proc.stdout.read, daemon=True).start()  # keep its pipe drained
            return proc
    raise SystemExit(f"{cmd} ended before printing {ready!r}")


def _stager(nodes: list[dict], env: dict[str, str]) -> subprocess.Popen:
    return _start([sys.executable, str(HERE / "tf_stager.py"), json.dumps({"nodes": nodes})], env, "staged")


def main() -> int:
    sys.path.insert(0, str(HERE))
    from conftest import free_port

    out = Path(sys.argv[1] if len(sys.argv) > 1 else HERE / "data" / "tf_doctor_staged.mcap")
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env.update(ZENTF_LOCAL_PORT=str(free_port()), PYTHONUNBUFFERED="1")
    procs = []
    try:
        recorder = _start([sys.executable, "-m", "zentf.cli", "bag", "record", "tf", "tf_static", "-o", str(out)],
                          env, "recording")
        procs.append(_stager([
            {"name": "healthy1", "sends": [_send("world", "a1"), _send("a1", "b1"), _send("c1", "d1"),
                                           _send("d1", "e1")]},
            {"name": "dup_a", "sends": [_send("world", "payload", 10.0)]},
            {"name": "dup_b", "sends": [_send("world", "payload", 10.0)]},
            {"name": "laggard", "sends": [_send("a1", "gimbal", 10.0, offset=-2.5)]},
            {"name": "cam_static", "sends": [_send("a1", "camera", static=True, translation=[0.1, 0, 0])]},
            {"name": "cam_on_tf", "sends": [_send("a1", "camera", 5.0, translation=[0.1, 0, 0])]},
        ], env))
        stale = _stager([{"name": "stale1", "sends": [_send("b1", "c1", stop_on="SIGUSR1")]}], env)
        doomed = _stager([{"name": "doomed", "sends": [_send("world", "beacon", 10.0)]}], env)
        procs += [stale, doomed]
        time.sleep(3.0)
        doomed.kill()  # a crash: no goodbye
        stale.send_signal(signal.SIGUSR1)  # alive, but silent
        time.sleep(3.0)  # longer than the dead limit (5 periods and 1 s)
        recorder.send_signal(signal.SIGINT)
        if recorder.wait(30) != 0:
            raise SystemExit("the recorder failed")
    finally:
        for p in procs:
            p.terminate()
        for p in procs:
            try:
                p.wait(30)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
    print(f"wrote {out} ({out.stat().st_size} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
