"""The wire profile as one interface: nothing outside zentf/transport/wire asks which wire it is, both
siblings implement every method, and what nodes build on it behaves alike on both wires: raw
subscriptions (payload, sender, key, carried type; latched history; patterns), declared graph entities,
and subscription counts read from the graph."""
from __future__ import annotations

import re
import threading
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from zentf.core.messages import Header, Point, PointStamped
from zentf.core.time import Time
from zentf.transport.graph import GraphWatcher, node_info
from zentf.transport.node import Node, RawSample
from zentf.transport.options import NodeOptions, ZenohOptions
from zentf.transport.wire.base import WireProfile
from zentf.transport.wire.profiles import Ros2Profile, ZentfProfile

ZENTF = Path(__file__).resolve().parent.parent / "zentf"
#: a decision made on the wire's name (or the profile's class) instead of asking the profile
BY_NAME = re.compile(r"""(\bwire|profile)\.name\s*(==|!=|\bin\b)|\.name\s*(==|!=)\s*["'](zentf|ros2)["']"""
                     r"""|isinstance\([^)]*,\s*\(?(Ros2Profile|ZentfProfile)""")
#: reaching into another object's private state the profile should be asked for
PRIVATE = re.compile(r"node\._(namespace|ros2_id|declare_entity)\b")


def test_no_code_outside_the_wire_package_decides_by_the_wire_name() -> None:
    wire_dir = ZENTF / "transport" / "wire"
    hits = []
    for path in sorted(ZENTF.rglob("*.py")) + sorted(ZENTF.rglob("*.pyx")):
        text = path.read_text()
        for pattern in ((PRIVATE,) if wire_dir in path.parents else (BY_NAME, PRIVATE)):
            hits += [f"{path.relative_to(ZENTF.parent)}:{text.count(chr(10), 0, m.start()) + 1}: {m.group(0)}"
                     for m in pattern.finditer(text)]
    assert not hits, "\n".join(hits)


def test_both_wires_implement_the_whole_interface() -> None:
    with pytest.raises(TypeError, match="abstract"):
        WireProfile()  # type: ignore[abstract]
    for profile in (ZentfProfile(), Ros2Profile(7)):
        assert profile.payload_format in ("msgpack", "cdr")
        assert profile == type(profile)(*([7] if isinstance(profile, Ros2Profile) else []))
    assert ZentfProfile() != Ros2Profile(0) and Ros2Profile(1) != Ros2Profile(2)


@pytest.fixture(params=["zentf", "ros2"])
def wire_options(request, zenoh_router: str) -> NodeOptions:
    """Node options on the test's wire: zentf's in a namespace of its own, ROS 2's in its own domain too."""
    return NodeOptions(namespace=f"t_{uuid.uuid4().hex[:10]}", wire=request.param,
                       domain_id=1 + uuid.uuid4().int % 200,
                       zenoh=ZenohOptions(connect=[zenoh_router], no_multicast=True, mode="client"))


@pytest.fixture
def nodes(wire_options: NodeOptions) -> Iterator[tuple[Node, Node]]:
    with Node("talker", options=wire_options) as a, Node("hearer", options=wire_options) as b:
        yield a, b


class Samples:
    """RawSamples as a raw subscription's callback gets them."""

    def __init__(self) -> None:
        self.got: list[RawSample] = []
        self.cond = threading.Condition()

    def __call__(self, sample: RawSample) -> None:
        with self.cond:
            self.got.append(sample)
            self.cond.notify_all()

    def wait(self, n: int = 1, timeout: float = 20.0) -> list[RawSample]:
        with self.cond:
            assert self.cond.wait_for(lambda: len(self.got) >= n, timeout), f"{len(self.got)} of {n} samples"
            return list(self.got)

    def wait_for(self, wanted: Callable[[RawSample], bool], timeout: float = 20.0) -> RawSample:
        """The first sample ``wanted`` accepts, once one has come (others may come before it)."""
        with self.cond:
            assert self.cond.wait_for(lambda: any(wanted(s) for s in self.got), timeout), \
                f"none of {len(self.got)} samples was the one wanted"
            return next(s for s in self.got if wanted(s))


def point(x: float) -> PointStamped:
    return PointStamped(Header(Time(sec=3), "laser"), Point(x, 0.0, 0.0))


def test_raw_subscription_gets_payload_sender_key_and_type(nodes) -> None:
    a, b = nodes
    latched = a.create_publisher("latched_points", PointStamped, latched=True)
    latched.publish(point(1.0))  # before anyone listens: a latched subscription still gets it
    late, plain, every = Samples(), Samples(), Samples()
    b.create_raw_subscription("latched_points", late, type_name=PointStamped, latched=True)
    sub = b.create_raw_subscription("points", plain, type_name=PointStamped)
    b.create_raw_subscription("**", every)  # a pattern: every topic of b's namespace, any type
    pub = a.create_publisher("points", PointStamped)
    assert pub.wait_for_subscribers(20)
    pub.publish(point(2.0))

    s = late.wait()[0]
    assert b.wire.decode(s.payload, s.encoding, s.key, PointStamped).point.x == 1.0
    s = plain.wait()[0]
    assert s.key == sub.key == b.topic_key("points", PointStamped.TYPE_NAME)
    assert s.type_name == PointStamped.TYPE_NAME
    assert b.wire.decode(s.payload, s.encoding, s.key, PointStamped) == point(2.0)
    assert b.wire.sender_id(s.attachment) == pub.sender_id  # who sent it, on either wire
    assert b.wire.authority(s.attachment, "?") == ("/" + a.get_namespace().strip("/") + "/talker"
                                                   if b.wire.fixed_authority is None else b.wire.fixed_authority)
    # the pattern gets the points (the latched topic's sample may come to it too, before or after)
    topic = b.resolve_topic_name("points")
    assert every.wait_for(lambda s: b.wire.topic_of_key(s.key)[0] == topic).payload == plain.wait()[0].payload

    # the typed raw subscription is in the graph; the pattern is not (a token holds no wildcard)
    info = node_info(b.session, b.get_fully_qualified_name(), profile=b.wire)
    assert info is not None and info.subscriptions == [(b.resolve_topic_name("latched_points"), PointStamped.TYPE_NAME),
                                                       (b.resolve_topic_name("points"), PointStamped.TYPE_NAME)]


def test_raw_subscription_drops_puts_on_wildcard_keys(nodes) -> None:
    """A put on a key expression with wildcards reaches every subscription it intersects, under that
    wildcard: no topic's message, so a raw subscription (and all that use one) never hands it over."""
    a, b = nodes
    got = Samples()
    sub = b.create_raw_subscription("points", got, type_name=PointStamped)
    pub = a.create_publisher("points", PointStamped)
    assert pub.wait_for_subscribers(20)
    payload = a.wire.encode(point(6.0), PointStamped.TYPE_NAME)
    wild = sub.key.rsplit("/", 1)[0] + "/*"  # intersects this subscription's key only
    a.session.put(wild, payload, encoding=a.wire.encoding(PointStamped.TYPE_NAME), attachment=b"/forger")
    pub.publish(point(1.0))  # sent after the wildcard put: once it is in, the other was seen and dropped
    s = got.wait()[0]
    assert b.wire.decode(s.payload, s.encoding, s.key, PointStamped).point.x == 1.0 and len(got.got) == 1
    assert sub.errors == 1 and sub.received == 2


def test_declare_entity_announces_in_the_wire_layout(nodes) -> None:
    a, _ = nodes
    topic = a.resolve_topic_name("announced")
    token = a.declare_entity("pub", topic, PointStamped.TYPE_NAME, depth=5)
    assert a.wire.parse_token(token.key).topic == topic
    info = node_info(a.session, a.get_fully_qualified_name(), profile=a.wire)
    assert info is not None and (topic, PointStamped.TYPE_NAME) in info.publishers
    token.undeclare()
    info = node_info(a.session, a.get_fully_qualified_name(), profile=a.wire)
    assert info is not None and (topic, PointStamped.TYPE_NAME) not in info.publishers
    with pytest.raises(ValueError, match="fully qualified"):
        a.declare_entity("pub", "relative", PointStamped.TYPE_NAME)


def test_subscription_counts_follow_the_graph(wire_options: NodeOptions) -> None:
    other_session = wire_options.zenoh.open_session()  # sees the token once the router has it
    with Node("first_ear", options=wire_options) as ear, \
            GraphWatcher(other_session, profile=ear.wire) as watch:
        ear.create_subscription("chatter", PointStamped, lambda m: None)
        assert watch.wait_for(lambda es: any(e.kind == "sub" and e.name == "first_ear" for e in es), 20)
        with Node("speaker", options=wire_options) as speaker, Node("second_ear", options=wire_options) as ear2:
            pub = speaker.create_publisher("chatter", PointStamped)
            graph = speaker._graph_view()  # the view the counts read: waited on here instead of polling

            def settles(check) -> bool:
                return graph.wait_for(lambda _: check(), 20)

            assert pub.get_subscription_count() == 1  # known at the first call: the view asked the network
            sub2 = ear2.create_subscription("chatter", PointStamped, lambda m: None)
            ear2.create_subscription("other", PointStamped, lambda m: None)  # another topic: not counted
            assert settles(lambda: speaker.count_subscribers("other") == 1)
            assert settles(lambda: pub.get_subscription_count() == 2)
            assert speaker.count_subscribers("chatter") == 2 and speaker.count_publishers("chatter") == 1
            assert speaker.count_publishers("other") == 0
            sub2.destroy()
            assert settles(lambda: pub.get_subscription_count() == 1)
        assert ear.count_publishers("chatter") == 0 or ear._graph_view().wait_for(
            lambda _: ear.count_publishers("chatter") == 0, 20)
    other_session.close()
