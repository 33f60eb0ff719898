"""Launcher benchmark: `zentf launch` of the drones and turtles graphs, side by side with starting the
same node programs by hand (one Popen each, in parallel, no launcher), measured in the same run.

    python bench/launch.py [--runs 3]

Per graph and run, with a fresh namespace on a local router (client mode, no multicast):
  live      wall time from the start command to every node's liveliness token being seen
  first tf  wall time to the first message on <ns>/tf or <ns>/tf_static
  stop      wall time from SIGINT (to the launcher; to every process for the reference) until every
            process has exited
Targets (issue 4): live < 1.5 s and stop < 1 s on this 2-core machine. The reference shows what
Python + Zenoh start-up alone costs, so the ratio is the launcher's own overhead.
"""
from __future__ import annotations

import argparse
import os
import signal
import socket
import statistics
import subprocess
import sys
import threading
import time
import uuid
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

GRAPHS: dict[str, list[tuple[str, str, dict]]] = {
    # graph -> [(node name, module, params)] exactly as the launch file starts them
    "drones": [("frames_publisher", "nodes.frames_publisher", {"static": False, "rate": 50}),
               ("plots_publisher", "nodes.plots_publisher", {"rate": 10})],
    "turtles": [("turtlesim", "nodes.turtlesim", {}),
                ("turtle1_tf_broadcaster", "nodes.turtle_tf_broadcaster", {"turtlename": "turtle1"}),
                ("turtle2_tf_broadcaster", "nodes.turtle_tf_broadcaster", {"turtlename": "turtle2"}),
                ("follower", "nodes.turtle_follower", {"turtlename": "turtle2", "target_frame": "turtle1"}),
                ("teleop", "nodes.turtle_teleop", {"turtlename": "turtle1", "pattern": "circle"})],
}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Observer:
    """Liveliness watcher + first-tf detector for one namespace, on its own Zenoh session."""

    def __init__(self, session, namespace: str, names: set[str]) -> None:
        from zentf.transport.graph import GraphWatcher

        self.names = names
        self.live_at: float | None = None
        self.tf_at: float | None = None
        self._done = threading.Condition()
        self.watcher = GraphWatcher(session, self._on_change, namespace=namespace)
        self._subs = [session.declare_subscriber(f"{namespace}/tf", self._on_tf),
                      session.declare_subscriber(f"{namespace}/tf_static", self._on_tf)]

    def _on_change(self, entry, alive: bool) -> None:
        if self.live_at is None and alive:
            nodes, _ = self.watcher.snapshot()
            if self.names <= {n.rsplit("/", 1)[-1] for n in nodes}:
                with self._done:
                    self.live_at = time.monotonic()
                    self._done.notify_all()

    def _on_tf(self, sample) -> None:
        if self.tf_at is None:
            with self._done:
                self.tf_at = time.monotonic()
                self._done.notify_all()

    def wait(self, timeout: float = 60.0) -> bool:
        with self._done:
            return self._done.wait_for(lambda: self.live_at is not None and self.tf_at is not None, timeout)

    def close(self) -> None:
        self.watcher.close()
        for s in self._subs:
            s.undeclare()


def child_env(router: str, namespace: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env.update(ZENTF_CONNECT=router, ZENTF_MODE="client", ZENTF_NO_MULTICAST="1", ZENTF_NAMESPACE=namespace,
               PYTHONUNBUFFERED="1")
    return env


def wait_all(procs: list[subprocess.Popen], timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    for p in procs:
        try:
            p.wait(max(0.01, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            p.kill()
            p.wait()


def run_once(session, router: str, graph: str, use_launcher: bool) -> tuple[float, float, float]:
    import json

    ns = f"bench_{uuid.uuid4().hex[:8]}"
    names = {n for n, _, _ in GRAPHS[graph]}
    obs = Observer(session, ns, names)
    env = child_env(router, ns)
    procs: list[subprocess.Popen] = []
    try:
        t0 = time.monotonic()
        if use_launcher:
            procs.append(subprocess.Popen([sys.executable, "-m", "zentf.cli", "launch", graph], env=env,
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=REPO))
        else:
            for name, module, params in GRAPHS[graph]:
                e = dict(env, ZENTF_NODE_NAME=name, ZENTF_PARAMS=json.dumps(params))
                procs.append(subprocess.Popen([sys.executable, "-m", module], env=e, stdout=subprocess.DEVNULL,
                                              stderr=subprocess.DEVNULL, cwd=REPO, start_new_session=True))
        if not obs.wait():
            raise RuntimeError(f"{graph}: not live within 60 s (live={obs.live_at}, tf={obs.tf_at})")
        live, first_tf = obs.live_at - t0, obs.tf_at - t0  # type: ignore[operator]
        t1 = time.monotonic()
        for p in procs:
            p.send_signal(signal.SIGINT)
        wait_all(procs)
        stop = time.monotonic() - t1
        return live, first_tf, stop
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
        obs.close()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    from zentf.transport.options import ZenohOptions

    router_ep = f"tcp/127.0.0.1:{free_port()}"
    router = subprocess.Popen([sys.executable, "-m", "zentf.transport.router", "--listen", router_ep, "--no-multicast"],
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        assert router.stdout is not None
        line = router.stdout.readline()
        if "listening" not in line:
            print(f"router did not start: {line}", file=sys.stderr)
            return 1
        session = ZenohOptions(connect=[router_ep], mode="client", no_multicast=True).open_session()
        rows = []
        try:
            for graph in GRAPHS:
                res = {}
                for use_launcher in (True, False):
                    samples = [run_once(session, router_ep, graph, use_launcher) for _ in range(args.runs)]
                    res[use_launcher] = [statistics.median(col) for col in zip(*samples)]
                rows.append((graph, len(GRAPHS[graph]), res[True], res[False]))
        finally:
            session.close()
    finally:
        router.send_signal(signal.SIGINT)
        try:
            router.wait(5)
        except subprocess.TimeoutExpired:
            router.kill()
    print(f"\nzentf launch vs the same nodes started by hand (median of {args.runs} runs, seconds, "
          f"{os.cpu_count()} cores)\n")
    print(f"{'graph':<9}{'nodes':>6}  {'metric':<9}{'zentf launch':>13}{'by hand':>10}{'ratio':>8}{'target':>9}")
    for graph, n, launched, manual in rows:
        for i, (metric, target) in enumerate((("live", "< 1.5"), ("first tf", ""), ("stop", "< 1.0"))):
            ratio = launched[i] / manual[i] if manual[i] > 0 else float("nan")
            print(f"{graph if i == 0 else '':<9}{n if i == 0 else '':>6}  {metric:<9}{launched[i]:>13.3f}"
                  f"{manual[i]:>10.3f}{ratio:>8.2f}{target:>9}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
