"""The ros2 wire profile's pieces, checked against rmw_zenoh's documented formats and zenoh-ext's own
serializer: data keys, attachments, graph tokens, QoS strings, options; then zentf nodes talking to each
other with ``--wire ros2`` through a real router (keys on the wire, tokens in the graph, latched statics)."""
from __future__ import annotations

import math
import time
import uuid

import pytest

from zentf.transport.options import NodeOptions, OptionsError
from zentf.transport.wire.profiles import (Ros2Profile, WireProfile, ZentfProfile, make_profile,
                                          parse_ros2_attachment, parse_ros2_token, qos_string, ros2_attachment)

TF = "tf2_msgs/msg/TFMessage"
TF_KEY = ("0/tf/tf2_msgs::msg::dds_::TFMessage_/"
          "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087")


def test_data_keys_follow_rmw_zenoh() -> None:
    p = Ros2Profile(0)
    assert p.data_key("/tf", TF) == TF_KEY                     # issue 14's example, byte for byte
    assert p.data_key("/robot1/tf", TF).startswith("0/robot1/tf/tf2_msgs::msg::dds_::TFMessage_/RIHS01_")
    assert Ros2Profile(7).data_key("/clock", "rosgraph_msgs/msg/Clock").startswith(
        "7/clock/rosgraph_msgs::msg::dds_::Clock_/RIHS01_")
    assert p.data_key("/robot1/tf", None) == "0/robot1/tf/*/*"  # any type (topic echo)
    assert p.topic_of_key(TF_KEY) == ("/tf", TF)
    with pytest.raises(ValueError, match="no ROS 2 definition"):
        p.data_key("/x", "my_msgs/msg/Unknown")


def test_attachment_is_zenoh_ext_serialization_of_seq_stamp_gid() -> None:
    zx = pytest.importorskip("zenoh.ext")
    gid = bytes(range(16))
    ours = ros2_attachment(42, 1_700_000_000_123456789, gid)
    # zenoh-ext's serializer (what rmw_zenoh's C++ uses): (int64, int64, uint8[16]) -> 8 + 8 + LEB128 len + 16
    ref = zx.z_serialize((zx.Int64(42), zx.Int64(1_700_000_000_123456789), gid)).to_bytes()
    assert ours == ref and len(ours) == 33
    assert parse_ros2_attachment(ours) == (42, 1_700_000_000_123456789, gid)
    # Jazzy 0.2.0-0.2.3 wrote the field names too ("sequence_number", value, ...)
    keyed = b"".join(zx.z_serialize(x).to_bytes() for x in
                     ("sequence_number", zx.Int64(7), "source_timestamp", zx.Int64(99), "source_gid", gid))
    assert parse_ros2_attachment(keyed) == (7, 99, gid)
    for bad in (b"", b"zentf-node", ours[:20]):
        with pytest.raises(ValueError):
            parse_ros2_attachment(bad)


def test_qos_strings_match_rmw_zenoh() -> None:
    assert qos_string(depth=100) == "::,100:,:,:,,"                 # a tf broadcaster
    assert qos_string(depth=1, latched=True) == ":1:,1:,:,:,,"      # /tf_static
    assert qos_string() == "::,:,:,:,,"                             # every policy at rmw_zenoh's default
    assert qos_string(depth=10, best_effort=True) == "2::,10:,:,:,,"


def test_tokens_of_rmw_zenoh_parse_into_the_graph() -> None:
    # the examples of rmw_zenoh's docs/design.md
    node = "@ros2_lv/0/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener"
    sub = ("@ros2_lv/0/aac3178e146ba6f1fc6e6a4085e77f21/0/10/MS/%/%/listener/%chatter/std_msgs::msg::dds_::String_/"
           "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,10:,:,:,,")
    pub = ("@ros2_lv/0/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%robot1/talker/%robot1%chatter/"
           "std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/"
           "::,7:,:,:,,")
    e = parse_ros2_token(node)
    assert (e.kind, e.namespace, e.name, e.node) == ("node", "", "listener", "/listener")
    e = parse_ros2_token(sub)
    assert (e.kind, e.topic, e.type_name, e.node) == ("sub", "/chatter", "std_msgs/msg/String", "/listener")
    e = parse_ros2_token(pub)
    assert (e.kind, e.topic, e.node) == ("pub", "/robot1/chatter", "/robot1/talker")
    service = node.replace("/NN/", "/SS/") + "/%add/example_interfaces::srv::dds_::AddTwoInts_/RIHS01_x/::,10:,:,:,,"
    e = parse_ros2_token(service)  # service servers (SS) and clients (SC) are in the graph too
    assert (e.kind, e.topic, e.type_name, e.node) == ("srv", "/add", "example_interfaces/srv/AddTwoInts", "/listener")
    assert parse_ros2_token(service.replace("/SS/", "/SC/")).kind == "cli"
    for other in ("@zentf/node/%/x", "@ros2_lv/0/z", node.replace("/%/%/", "/%/bad-ns/")):
        assert parse_ros2_token(other) is None
    assert Ros2Profile(3).parse_token(node) is None                 # another domain


def test_profile_and_domain_options() -> None:
    assert isinstance(make_profile(None), ZentfProfile) and isinstance(make_profile("ros2"), WireProfile)
    assert make_profile("ros2", "5").domain_id == 5
    for bad in ("dds", "ROS3"):
        with pytest.raises(ValueError, match="unknown wire profile"):
            make_profile(bad)
    opts = NodeOptions.from_env({"ZENTF_WIRE": "ros2", "ROS_DOMAIN_ID": "12"})
    assert (opts.wire, opts.domain_id) == ("ros2", 12)
    assert opts.to_env()["ZENTF_WIRE"] == "ros2" and opts.to_env()["ROS_DOMAIN_ID"] == "12"
    assert NodeOptions.from_args(["--wire", "ros2"], env={}).wire == "ros2"
    for env, needle in (({"ZENTF_WIRE": "dds"}, "bad wire profile"), ({"ROS_DOMAIN_ID": "x"}, "ROS_DOMAIN_ID"),
                        ({"ROS_DOMAIN_ID": "300"}, "0-232")):
        with pytest.raises(OptionsError, match=needle) as exc:
            NodeOptions.from_env(env)
        assert "\n" not in str(exc.value)


def test_ros2_machine_session_defaults_only_when_nothing_was_given() -> None:
    from zentf.transport.options import ZenohOptions

    p = Ros2Profile()
    z = p.session_defaults(ZenohOptions())
    assert (z.connect, z.mode, z.no_multicast) == (["tcp/localhost:7447"], "peer", True)
    given = ZenohOptions(connect=["tcp/10.0.0.2:7447"], mode="client")
    assert p.session_defaults(given) is given
    assert ZentfProfile().session_defaults(ZenohOptions()).connect == []


# ---- live: zentf nodes with --wire ros2 through a router

@pytest.fixture
def ros2_options(isolated_router: str):
    """NodeOptions of a ROS 2 node on this test's own router, in a domain of its own."""
    from zentf.transport.options import ZenohOptions

    domain = 1 + uuid.uuid4().int % 200
    return NodeOptions(wire="ros2", domain_id=domain,
                       zenoh=ZenohOptions(connect=[isolated_router], no_multicast=True, mode="client"))


def _wait(pred, timeout: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if pred():
            return True
        time.sleep(0.02)
    return pred()


def test_zentf_nodes_speak_ros2_on_the_wire(ros2_options) -> None:
    from zentf.transport.broadcaster import StaticTransformBroadcaster, TransformBroadcaster
    from zentf.transport.buffer import Buffer
    from zentf.core.messages import Header, PointStamped, Point, Transform, TransformStamped, Vector3
    from zentf.core.time import Time
    from zentf.transport.graph import GraphWatcher
    from zentf.transport.listener import TransformListener
    from zentf.transport.message_filter import MessageFilter
    from zentf.transport.node import Node

    dom = ros2_options.domain_id
    raw = ros2_options.zenoh.open_session()
    seen: list = []
    spy = raw.declare_subscriber(f"{dom}/**", lambda s: seen.append(
        (str(s.key_expr), s.payload.to_bytes(), s.attachment.to_bytes() if s.attachment is not None else None)))
    pub_node = Node("tf_pub", options=ros2_options)
    sub_node = Node("tf_sub", options=ros2_options)
    watcher = GraphWatcher(raw, profile=pub_node.wire)
    try:
        static = StaticTransformBroadcaster(pub_node)
        static.send_transform(TransformStamped(Header(Time(sec=1), "map"), "odom", Transform(Vector3(1, 2, 3))))
        buf = Buffer()
        listener = TransformListener(buf, sub_node)   # starts after the static was sent: latched history
        points: list = []
        mf = MessageFilter("points", buf, "map", 10, 5.0, node=sub_node, msg_type=PointStamped,
                           callback=points.append)  # delivers each point once it can be put in map
        assert watcher.wait_for(lambda es: any(e.kind == "sub" and e.topic == "/points" for e in es), 10)
        tf = TransformBroadcaster(pub_node)
        pts = pub_node.create_publisher("points", PointStamped)
        assert _wait(lambda: buf.can_transform("map", "odom", Time()), 10)
        for i in range(1, 6):
            stamp = Time(nanoseconds=time.time_ns())
            pts.publish(PointStamped(Header(stamp, "base_link"), Point(i, 0, 0)))  # before its transform
            time.sleep(0.01)
            tf.send_transform(TransformStamped(Header(stamp, "odom"), "base_link", Transform(Vector3(0.5 * i, 0, 0))))
            time.sleep(0.02)
        assert _wait(lambda: len(points) == 5 and buf.can_transform("map", "base_link", Time()))
        t = buf.lookup_transform("map", "base_link", Time())
        assert math.isclose(t.transform.translation.x, 3.5) and t.transform.translation.y == 2.0
        assert [p.point.x for p in points] == [1, 2, 3, 4, 5] and mf.delivered == 5
        assert "Authority undetectable" in buf.all_frames_as_yaml()
        assert listener.stats()["malformed"] == 0
        # on the wire: rmw_zenoh keys, CDR, 33-byte attachments with per-publisher sequence numbers
        tf_samples = [s for s in seen if s[0] == f"{dom}/tf/tf2_msgs::msg::dds_::TFMessage_/{TF_KEY.rsplit('/', 1)[1]}"]
        assert len(tf_samples) == 5 and all(s[1][:4] == b"\x00\x01\x00\x00" for s in tf_samples)
        atts = [parse_ros2_attachment(s[2]) for s in tf_samples]
        assert [a[0] for a in atts] == [1, 2, 3, 4, 5] and len({a[2] for a in atts}) == 1
        assert all(abs(a[1] - time.time_ns()) < 60e9 for a in atts)
        # in the graph: @ros2_lv tokens that zentf's graph reads back
        nodes, topics = watcher.snapshot()
        assert {"/tf_pub", "/tf_sub"} <= set(nodes)
        assert topics["/tf"].types == [TF] and topics["/tf"].publishers == ["/tf_pub"]
        assert "/tf_sub" in topics["/tf_static"].subscribers
        tokens: list[str] = []  # the tokens as a ROS 2 graph cache sees them (history + live)
        tok_sub = raw.liveliness().declare_subscriber(f"@ros2_lv/{dom}/**", lambda s: tokens.append(str(s.key_expr)),
                                                      history=True)
        expected = (  # each a token that must be among them (the nodes' service tokens come too, any order)
            lambda k: k.endswith("/MP/%/%/tf_pub/%tf/tf2_msgs::msg::dds_::TFMessage_/" + TF_KEY.rsplit("/", 1)[1]
                                 + "/::,100:,:,:,,"),
            lambda k: "/MP/%/%/tf_pub/%tf_static/" in k and k.endswith("/:1:,1:,:,:,,"),
            lambda k: k.endswith("/NN/%/%/tf_sub"))
        # (waiting for "5 of them" raced: the services' tokens could fill the count before the publisher's)
        assert _wait(lambda: all(any(e(k) for k in list(tokens)) for e in expected), 10), tokens
        tok_sub.undeclare()
        # the GID in the attachments is rmw_zenoh's: XXH3-128 of the publisher's token, low then high 64 bits
        xxhash = pytest.importorskip("xxhash")
        (tf_token,) = [k for k in tokens if "/MP/%/%/tf_pub/%tf/" in k]
        assert atts[0][2] == xxhash.xxh3_128_intdigest(tf_token.encode()).to_bytes(16, "little")
    finally:
        watcher.close()
        spy.undeclare()
        pub_node.shutdown()
        sub_node.shutdown()
        raw.close()


def test_bad_cdr_on_a_ros2_topic_is_dropped_with_one_line(ros2_options, caplog) -> None:
    from zentf.transport.buffer import Buffer
    from zentf.core.messages import PointStamped
    from zentf.transport.listener import TransformListener
    from zentf.transport.node import Node

    node = Node("victim", options=ros2_options)
    raw = ros2_options.zenoh.open_session()
    try:
        buf = Buffer()
        listener = TransformListener(buf, node)
        got: list = []
        sub = node.create_subscription("points", PointStamped, got.append)
        pubs = [raw.declare_publisher(node.wire.data_key("/tf", TF)),
                raw.declare_publisher(node.wire.data_key("/points", PointStamped.TYPE_NAME))]
        # the router must know both subscribers before the junk goes out (their declarations queue behind
        # the node's others, e.g. its parameter services)
        assert _wait(lambda: all(p.matching_status.matching for p in pubs))
        for junk in (b"", b"\x00\x01\x00\x00\xff\xff\xff\x7f", b"garbage that is not cdr"):
            for p in pubs:
                p.put(junk)
        assert _wait(lambda: listener.stats()["bad_messages"] == 3 and sub.errors == 3)
        assert buf.get_frames() == []
        assert got == []
    finally:
        node.shutdown()
        raw.close()


def test_cli_wire_errors_are_one_line_usage_errors(isolated_router: str) -> None:
    from cli_helpers import assert_one_line_error, zentf
    from conftest import child_env

    env = child_env(isolated_router, "")
    env.update({"ZENTF_WIRE": "ros2", "ROS_DOMAIN_ID": "abc"})
    assert_one_line_error(zentf(["topic", "list", "--wait", "0.2"], env), "ROS_DOMAIN_ID", code=2)
    env["ROS_DOMAIN_ID"] = "0"
    assert_one_line_error(zentf(["node", "list", "--wire", "dds"], env), "--wire", code=2)
    env["ZENTF_WIRE"] = "dds"
    assert_one_line_error(zentf(["node", "list", "--wait", "0.2"], env), "wire profile", code=2)


def test_a_ros2_sender_is_its_publisher_gid_for_the_listener_queues() -> None:
    """The listener queues tf per sender: under ros2 the attachment's sequence number and time change
    with every sample, so the sender must be the GID (else every sample is a new sender, a flooder is
    never isolated and ingest halves)."""
    gid_a, gid_b = bytes(range(16)), bytes(range(1, 17))
    first, second = ros2_attachment(1, 10, gid_a), ros2_attachment(2, 20, gid_a)
    assert first != second
    assert Ros2Profile.sender_of(first) == Ros2Profile.sender_of(second) == gid_a
    assert Ros2Profile.sender_of(ros2_attachment(1, 10, gid_b)) == gid_b
    assert Ros2Profile.sender_of(b"other layout") == b"other layout"
    assert ZentfProfile.sender_of is None  # zentf's attachment is the node name itself


def test_a_ros2_backlog_is_queued_as_cdr_bytes_and_inserted_in_order(ros2_options) -> None:
    """Under --wire ros2 a listener's per-sender queue also keeps a backlog as the CDR payloads' bytes
    (TfHandler.queued: the Zenoh samples go at once), and every transform still gets in, in the
    order sent (the sender is its publisher GID, one queue)."""
    from zentf.transport.ingest import thread
    from zentf.transport.broadcaster import TransformBroadcaster
    from zentf.transport.buffer import Buffer
    from zentf.core.messages import Header, Transform, TransformStamped, Vector3
    from zentf.core.time import Time
    from zentf.transport.listener import TransformListener
    from zentf.transport.node import Node

    count = 1000
    pub_node = Node("tf_flood", options=ros2_options)
    sub_node = Node("tf_sub", options=ros2_options)
    try:
        buf = Buffer()
        xs: list[float] = []

        def on_insert() -> None:  # slows the listener's thread (~10 lookups a message): a backlog forms
            for _ in range(10):
                x = buf.lookup_transform("world", "seq", Time()).transform.translation.x
            if not xs or xs[-1] != x:
                xs.append(x)

        buf.add_insert_callback(on_insert)
        listener = TransformListener(buf, sub_node)
        tf = TransformBroadcaster(pub_node)
        assert tf.wait_for_subscribers(10)
        before = thread.payload_messages()
        t0 = time.time_ns()
        msgs = [TransformStamped(Header(Time(nanoseconds=t0 + i), "world"), "seq", Transform(Vector3(float(i), 0, 0)))
                for i in range(count)]
        for m in msgs:
            tf.send_transform(m)
        assert _wait(lambda: bool(xs) and xs[-1] == count - 1, 30), (xs[-3:], listener.stats())
        assert xs == [float(i) for i in range(count)], [b for a, b in zip(xs, xs[1:]) if b != a + 1][:5]
        assert thread.payload_messages() - before > count // 2
        assert listener.stats()["dropped"] == 0
    finally:
        pub_node.shutdown()
        sub_node.shutdown()
