"""Shared fixtures: a Zenoh router hub on loopback, a unique namespace per test, and subprocess helpers.

Every test that talks Zenoh connects to the router endpoint with multicast scouting off and uses its
own namespace, so parallel workers (pytest-xdist) never cross-talk.
"""
from __future__ import annotations

import ctypes
import os
import queue
import re
import signal
import socket
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Iterator, Sequence
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parent.parent


#: Tests of 10 s or more on CI's 2 cores, longest first (a name without [params] covers every case). They
#: run before the rest: xdist hands tests out in collection order, and one of these started near the end
#: would run alone while the other worker idles. A renamed test just loses its place; nothing breaks.
LONG_FIRST = (
    "tests/test_cli_tf_doctor.py::test_doctor_on_a_healthy_drones_graph_reports_nothing",
    "tests/test_urdf_hostile.py::test_a_100000_link_chain_has_kinematics_a_publisher_and_a_view",
    "tests/test_readme.py::test_readme_run_things_block[zentf launch laser]",
    "tests/test_view_browser.py::test_view_web_shows_r2d2_in_one_framed_3d_view",
    "tests/test_urdf_hostile.py::test_a_100000_link_chain_checks_and_graphs",
    "tests/test_urdf_xacro.py::test_the_macro_bomb_stops_with_one_line_within_the_default_budget",
    "tests/test_transport_forged_tf_memory.py::test_big_tf_messages_leave_no_memory_behind",
    "tests/test_cli_tf_doctor.py::test_doctor_names_each_staged_problem_live_and_in_a_bag",
    "tests/test_bag_ros_play.py::test_nav2_played_with_clock_into_a_sim_time_listener_gives_the_reference_lookups",
    "tests/test_ros2_live.py::test_zentf_sees_a_ros2_node",
    "tests/test_cli_topic_tools.py::test_topic_delay_in_sim_time_and_on_the_wall_clock",
    "tests/test_urdf_hostile.py::test_a_100000_deep_mimic_chain_loads_in_linear_time",
    "tests/test_urdf_view.py::test_view_draws_r2d2_with_its_collada_meshes",
    "tests/test_cli_tf_doctor.py::test_tf_tools_read_a_fleet",
    "tests/test_readme.py::test_readme_run_things_block[zentf bag info tests/data/nav2_turtlebot]",
    "tests/test_transport_tfwire.py::test_msgpack_compiled_equals_python_on_well_formed_messages",
    "tests/test_transport_tfwire.py::test_cdr_compiled_equals_python_on_well_formed_messages",
    "tests/test_cli_tf_doctor.py::test_why_names_every_stale_edge_of_a_four_deep_chain",
    "tests/test_ros2_dds.py::test_two_bridges_one_relays_no_duplicates",
    "tests/test_ros2_dds.py::test_kilted_with_the_robot_setting",
    "tests/test_transport_service.py::test_zentf_service_list_type_call",
)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The LONG_FIRST tests first, in its order; the rest keep theirs (the sort is stable)."""
    rank = {name: i for i, name in enumerate(LONG_FIRST)}
    last = len(rank)
    items.sort(key=lambda item: rank.get(item.nodeid, rank.get(item.nodeid.split("[", 1)[0], last)))


def free_port() -> int:
    """A TCP port that is free on 127.0.0.1 right now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _die_with_parent() -> None:  # pragma: no cover - runs in the child before exec
    """Linux: the child gets SIGTERM if the test process dies, so nothing is orphaned."""
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except Exception:
        pass


class Proc:
    """A child process whose merged stdout/stderr lines are collected by a thread."""

    def __init__(self, args: Sequence[str], env: dict[str, str] | None = None, cwd: str | Path = REPO,
                 stdin: int | None = subprocess.DEVNULL) -> None:
        self.args = list(args)
        self.popen = subprocess.Popen(self.args, env=env, cwd=str(cwd), stdin=stdin, stdout=subprocess.PIPE,
                                      stderr=subprocess.STDOUT, text=True, bufsize=1,
                                      preexec_fn=_die_with_parent)
        self.lines: list[str] = []
        self._new: queue.Queue[str | None] = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self._cursor = 0

    def _read(self) -> None:
        assert self.popen.stdout is not None
        for line in self.popen.stdout:
            line = line.rstrip("\n")
            self.lines.append(line)
            self._new.put(line)
        self._new.put(None)

    @property
    def pid(self) -> int:
        return self.popen.pid

    @property
    def returncode(self) -> int | None:
        return self.popen.poll()

    def output(self) -> str:
        return "\n".join(self.lines)

    def wait_for_line(self, pattern: str, timeout: float = 10.0, *, from_start: bool = False) -> re.Match:
        """Wait for a line matching regex ``pattern`` (after the previous match); AssertionError on timeout."""
        rx = re.compile(pattern)
        if from_start:
            self._cursor = 0
        deadline = time.monotonic() + timeout
        while True:
            while self._cursor < len(self.lines):
                line = self.lines[self._cursor]
                self._cursor += 1
                m = rx.search(line)
                if m:
                    return m
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(f"no line matching {pattern!r} within {timeout}s from {self.args}; "
                                     f"rc={self.returncode}; output:\n{self.output()[-3000:]}")
            if not self._reader.is_alive() and self._cursor >= len(self.lines):
                self.popen.wait(5)
                raise AssertionError(f"process exited (rc={self.returncode}) before a line matching "
                                     f"{pattern!r}: {self.args}; output:\n{self.output()[-3000:]}")
            try:
                self._new.get(timeout=min(left, 0.5))
            except queue.Empty:
                pass

    def signal(self, sig: int) -> None:
        if self.popen.poll() is None:
            self.popen.send_signal(sig)

    def wait(self, timeout: float = 10.0) -> int:
        rc = self.popen.wait(timeout)
        self._reader.join(timeout=2)
        return rc

    def stop(self, timeout: float = 5.0) -> int | None:
        """SIGTERM, then SIGKILL after ``timeout``; returns the exit code."""
        if self.popen.poll() is None:
            self.popen.terminate()
            try:
                self.popen.wait(timeout)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait(5)
        self._reader.join(timeout=2)
        return self.popen.returncode

    def kill(self) -> None:
        if self.popen.poll() is None:
            self.popen.kill()
            self.popen.wait(5)


def start_router(endpoint: str | None = None) -> tuple[Proc, str]:
    """Start ``python -m zentf.transport.router`` on a free loopback port; returns (process, endpoint)."""
    for _ in range(5):
        ep = endpoint or f"tcp/127.0.0.1:{free_port()}"
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        proc = Proc([sys.executable, "-m", "zentf.transport.router", "--listen", ep, "--no-multicast"], env=env)
        try:
            proc.wait_for_line(r"listening on", timeout=20)
            return proc, ep
        except AssertionError:
            proc.stop()
            if endpoint:
                raise
    raise RuntimeError("could not start a zentf router")


@pytest.fixture(scope="session")
def zenoh_router() -> Iterator[str]:
    """Endpoint (``tcp/127.0.0.1:PORT``) of a router shared by this worker's tests; isolate by namespace."""
    proc, ep = start_router()
    try:
        yield ep
    finally:
        proc.stop()


@pytest.fixture
def isolated_router() -> Iterator[str]:
    """Endpoint of a router just for this test (for tests that use absolute topics like /clock)."""
    proc, ep = start_router()
    try:
        yield ep
    finally:
        proc.stop()


@pytest.fixture
def test_namespace() -> str:
    """A namespace unique to this test (``t_<hex>``)."""
    return f"t_{uuid.uuid4().hex[:10]}"


@pytest.fixture
def zenoh_options(zenoh_router: str):
    """ZenohOptions for in-process sessions: client of the router, multicast off.

    Client mode, not peer: a fresh peer only talks to other peers once gossip has built a direct
    link (its first puts are lost even though matching says yes); a client routes via the router at once.
    """
    from zentf.transport.options import ZenohOptions

    return ZenohOptions(connect=[zenoh_router], no_multicast=True, mode="client")


@pytest.fixture
def node_options(zenoh_options, test_namespace: str):
    """NodeOptions for an in-process Node in this test's namespace: ``Node('x', options=node_options)``."""
    from zentf.transport.options import NodeOptions

    return NodeOptions(namespace=test_namespace, zenoh=zenoh_options)


def matched_tf_publisher(session: object, node: object, type_name: str) -> object:
    """A raw Zenoh publisher on a node's ``tf`` key, labelled ``type_name`` (a forger's), once the node's
    listener is matched (event-driven)."""
    import zenoh

    from zentf.core.messages import TFMessage
    from zentf.transport.wire import codec as wire

    pub = session.declare_publisher(node.topic_key("tf", TFMessage.TYPE_NAME), encoding=wire.encoding_for(type_name),
                                    congestion_control=zenoh.CongestionControl.BLOCK)
    matched = threading.Event()
    listener = pub.declare_matching_listener(lambda status: status.matching and matched.set())
    try:
        assert matched.is_set() or pub.matching_status.matching or matched.wait(30), "no listener matched"
    finally:
        listener.undeclare()
    return pub


@pytest.fixture
def zenoh_session(zenoh_options) -> Iterator[object]:
    """A raw client-mode Zenoh session on the router (graph queries, raw puts, ...)."""
    s = zenoh_options.open_session()
    try:
        yield s
    finally:
        s.close()


@pytest.fixture
def zenoh_args(zenoh_router: str, test_namespace: str) -> list[str]:
    """Command-line flags for a child node program: connect to the router, multicast off, test namespace."""
    return ["--connect", zenoh_router, "--no-multicast", "--mode", "client", "--namespace", test_namespace]


def child_env(endpoint: str, namespace: str) -> dict[str, str]:
    """os.environ for a child process, with ZENTF_* set to: this router, client mode, no multicast,
    this namespace (identity and config variables from the outer environment removed)."""
    env = dict(os.environ)
    env.update({
        "ZENTF_CONNECT": endpoint,
        "ZENTF_NO_MULTICAST": "1",
        "ZENTF_MODE": "client",
        "ZENTF_NAMESPACE": namespace,
        "PYTHONUNBUFFERED": "1",
        "PYTHONPATH": os.pathsep.join(p for p in (str(REPO), env.get("PYTHONPATH", "")) if p),
    })
    for var in ("ZENTF_NODE_NAME", "ZENTF_PARAMS", "ZENTF_PARAMS_FILE", "ZENTF_REMAP", "ZENTF_ZENOH_CONFIG",
                "ZENTF_LISTEN"):
        env.pop(var, None)
    return env


@pytest.fixture
def zenoh_env(zenoh_router: str, test_namespace: str) -> dict[str, str]:
    """A full environment for child processes: os.environ + ZENTF_* (router, no multicast, namespace)."""
    return child_env(zenoh_router, test_namespace)


@pytest.fixture
def ros2_env(isolated_router: str) -> dict[str, str]:
    """Child env for a ROS 2 graph: this test's router, client mode, ZENTF_WIRE=ros2 in a ROS domain of its
    own, root namespace (ROS 2 topics are absolute)."""
    env = child_env(isolated_router, "")
    env.pop("ZENTF_NAMESPACE", None)
    env["ZENTF_WIRE"] = "ros2"
    env["ROS_DOMAIN_ID"] = str(1 + uuid.uuid4().int % 200)
    return env


def router_address(env: dict[str, str]) -> str:
    """The router a child env connects to, without the protocol (``tcp/127.0.0.1:7447`` -> ``127.0.0.1:7447``)."""
    return env["ZENTF_CONNECT"].split("/", 1)[1]


@pytest.fixture
def spawn(zenoh_env: dict[str, str]) -> Iterator:
    """Factory ``spawn(args, env=None, **kw) -> Proc`` (default env: zenoh_env); all are stopped at teardown.

    ``spawn.python('-m', 'nodes.x', ...)`` runs with this interpreter.
    """
    procs: list[Proc] = []

    def _spawn(args: Sequence[str], env: dict[str, str] | None = None, **kw: object) -> Proc:
        p = Proc(args, env=env if env is not None else zenoh_env, **kw)  # type: ignore[arg-type]
        procs.append(p)
        return p

    _spawn.python = lambda *args, env=None, **kw: _spawn([sys.executable, *args], env=env, **kw)  # type: ignore[attr-defined]
    try:
        yield _spawn
    finally:
        for p in procs:
            try:
                p.stop(timeout=3)
            except Exception:
                p.kill()
