"""zentf.ros against real ROS 2 bytes and an independent implementation (rosbags).

Every /tf and /tf_static message of a bag written by real ROS 2 decodes to the values rosbags' CDR
deserializer gives; re-encoded by zentf it decodes (by rosbags and by zentf) to the same values again.
Type hashes are computed from the definitions and compared with the hashes ROS 2 wrote into the bag and
with rosbags' own hashing. Values are compared, not bytes (real files carry non-zero padding).
"""
from __future__ import annotations

import math
import struct
from pathlib import Path

import pytest

from zentf.core.messages import (MESSAGE_TYPES, ColorRGBA, Header, Marker, Point, Pose, PoseStamped, Quaternion,
                                 TFMessage, Transform, TransformStamped, Vector3)
from zentf.core.time import Duration, Time
import zentf.core.parameters  # noqa: F401,E402  (every zentf type is registered, whatever ran before)
import zentf.core.services  # noqa: F401,E402
from zentf.ros import (CdrError, UnknownTypeError, dds_type_name, decode, decode_plain, definition, encode,
                       encode_tf, parse_schema, ros_type_name, serialize, tf_samples, type_hash)
from zentf.ros.typehash import type_hash as hash_of

rosbags_typesys = pytest.importorskip("rosbags.typesys")
mcap_reader = pytest.importorskip("mcap.reader")

BAG = Path(__file__).parent / "data" / "nav2_turtlebot.mcap"
TF = "tf2_msgs/msg/TFMessage"
#: the hash of tf2_msgs/msg/TFMessage as ROS 2 (Humble and later) writes it, quoted by issue 14
TF_HASH = "RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087"


@pytest.fixture(scope="module")
def store():
    return rosbags_typesys.get_typestore(rosbags_typesys.Stores.ROS2_JAZZY)


@pytest.fixture(scope="module")
def bag():
    """(channel topic, metadata, schema name, schema text, [payloads]) of the fixture's tf topics."""
    with BAG.open("rb") as f:
        reader = mcap_reader.make_reader(f)
        summary = reader.get_summary()
        msgs: dict[str, list[bytes]] = {"/tf": [], "/tf_static": []}
        for _, channel, message in reader.iter_messages(topics=list(msgs)):
            msgs[channel.topic].append(message.data)
    return summary, msgs


def _plain(obj) -> object:
    """A rosbags message (or numpy array) as plain Python data, for value comparison."""
    if hasattr(obj, "__dataclass_fields__"):
        # fields only: rosbags also lists a type's constants (upper case) and its type name
        return {k: _plain(getattr(obj, k)) for k in obj.__dataclass_fields__
                if k != "__msgtype__" and not k.isupper()}
    if hasattr(obj, "tolist"):
        return obj.tolist()
    if isinstance(obj, (list, tuple)):
        return [_plain(x) for x in obj]
    return obj


def _lists(v: object) -> object:
    """zentf gives uint8[] as bytes, rosbags as an array: compare both as lists of ints."""
    if isinstance(v, dict):
        return {k: _lists(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_lists(x) for x in v]
    return list(v) if isinstance(v, bytes) else v


def _sample_of(t) -> tuple:
    tr, q = t.transform.translation, t.transform.rotation
    return (t.header.frame_id, t.child_frame_id, t.header.stamp.sec * 1_000_000_000 + t.header.stamp.nanosec,
            tr.x, tr.y, tr.z, q.x, q.y, q.z, q.w)


def test_every_tf_message_of_a_real_bag_decodes_like_rosbags_and_round_trips(bag, store) -> None:
    _, msgs = bag
    assert len(msgs["/tf"]) == 5422 and len(msgs["/tf_static"]) == 1
    transforms = 0
    for payload in msgs["/tf"] + msgs["/tf_static"]:
        ref = store.deserialize_cdr(payload, TF)
        expected = [_sample_of(t) for t in ref.transforms]
        samples, malformed, problem = tf_samples(payload)          # the listener's fast path
        assert (samples, malformed, problem) == (expected, 0, None)
        plain = decode_plain(payload, TF)                           # the generic codec
        assert plain == _plain(ref)
        msg = decode(payload, TF)                                   # into zentf dataclasses
        assert isinstance(msg, TFMessage)
        assert [(t.header.frame_id, t.child_frame_id, t.header.stamp.nanoseconds, t.transform.translation.x,
                 t.transform.translation.y, t.transform.translation.z, t.transform.rotation.x,
                 t.transform.rotation.y, t.transform.rotation.z, t.transform.rotation.w)
                for t in msg.transforms] == expected
        for again in (encode(msg), encode_tf(plain["transforms"]), serialize(plain, TF, definition)):
            assert _plain(store.deserialize_cdr(again, TF)) == plain
            assert tf_samples(again)[0] == expected
        transforms += len(expected)
    assert transforms == 7313


def test_tf_static_of_the_bag_has_the_robot_frames(bag) -> None:
    (payload,) = bag[1]["/tf_static"]
    edges = {(s[0], s[1]) for s in tf_samples(payload)[0]}
    assert len(edges) == 29
    assert {("base_link", "base_footprint"), ("base_link", "imu_link"), ("oakd_link", "oakd_rgb_camera_frame")} <= edges


def test_type_hashes_are_computed_like_ros2(bag, store) -> None:
    summary, _ = bag
    assert type_hash(TF) == TF_HASH
    checked = set()
    for channel in summary.channels.values():
        schema = summary.schemas[channel.schema_id]
        defs = parse_schema(schema.name, schema.data.decode())   # the definitions ROS 2 stored in the bag
        assert hash_of(schema.name, defs) == channel.metadata["topic_type_hash"], schema.name
        checked.add(schema.name)
    assert checked == {TF, "nav_msgs/msg/Odometry", "geometry_msgs/msg/PoseWithCovarianceStamped"}
    compared = 0
    for name in MESSAGE_TYPES:
        if name not in store.fielddefs:   # turtlesim, std_srvs, service parts: not in rosbags' store
            continue
        assert type_hash(name) == store.hash_rihs01(name), name
        compared += 1
    assert compared >= 14


def test_schema_text_is_what_rosbag2_writes_and_hashes_the_same(bag) -> None:
    from zentf.ros import schema_text

    summary, _ = bag
    (tf_schema,) = {s.data.decode() for s in summary.schemas.values() if s.name == TF}
    ours = schema_text(TF)
    # same definitions as ROS 2 stored (comments aside): parsed alike, hashed alike
    assert parse_schema(TF, ours) == parse_schema(TF, tf_schema)
    for name in MESSAGE_TYPES:
        if "/msg/" in name:
            assert hash_of(name, parse_schema(name, schema_text(name))) == type_hash(name)


def test_dds_type_names() -> None:
    assert dds_type_name(TF) == "tf2_msgs::msg::dds_::TFMessage_"
    assert dds_type_name("rosgraph_msgs/msg/Clock") == "rosgraph_msgs::msg::dds_::Clock_"
    assert ros_type_name("geometry_msgs::msg::dds_::PointStamped_") == "geometry_msgs/msg/PointStamped"


def _example(cls):
    """A message with non-default values in every field zentf has."""
    header = Header(Time(sec=12, nanosec=345), "map")
    samples = {
        "std_msgs/msg/Header": header,
        "geometry_msgs/msg/Vector3": Vector3(1.5, -2.0, 3.25),
        "geometry_msgs/msg/Point": Point(0.1, 0.2, 0.3),
        "geometry_msgs/msg/Quaternion": Quaternion(0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)),
        "geometry_msgs/msg/Transform": Transform(Vector3(1, 2, 3), Quaternion(0, 0, 0, 1)),
        "geometry_msgs/msg/TransformStamped": TransformStamped(header, "base", Transform(Vector3(1, 2, 3))),
        "geometry_msgs/msg/Pose": Pose(Point(1, 2, 3), Quaternion(0, 1, 0, 0)),
        "geometry_msgs/msg/PoseStamped": PoseStamped(header, Pose(Point(4, 5, 6))),
        "std_msgs/msg/ColorRGBA": ColorRGBA(0.5, 0.25, 1.0, 0.75),
        "visualization_msgs/msg/Marker": Marker(header=header, ns="n", id=7, type=Marker.LINE_STRIP,
                                                pose=Pose(Point(1, 0, 0)), scale=Vector3(1, 1, 1),
                                                color=ColorRGBA(1, 0, 0, 1), lifetime=Duration(sec=2),
                                                frame_locked=True, points=[Point(1, 2, 3), Point(4, 5, 6)],
                                                colors=[ColorRGBA(0, 1, 0, 1)], text="hi"),
    }
    if cls.TYPE_NAME in samples:
        return samples[cls.TYPE_NAME]
    msg = cls()
    for name, tp in cls._fields():
        if tp is float:
            setattr(msg, name, 0.5)
        elif tp is int:
            setattr(msg, name, 3)
        elif tp is str:
            setattr(msg, name, "x")
        elif tp is Time:
            setattr(msg, name, Time(sec=5, nanosec=6))
        elif tp is Header:
            setattr(msg, name, header)
        elif isinstance(tp, type) and tp.__name__ in ("Vector3", "Point"):
            setattr(msg, name, tp(1.0, 2.0, 3.0))
    return msg


#: zentf's one-request form of tf2's LookupTransform action: no ROS 2 message has these names (ROS 2 has
#: _Goal/_Result), so they have no ROS 2 definition and do not travel with --wire ros2.
NOT_ROS2 = ("tf2_msgs/action/LookupTransform_Request", "tf2_msgs/action/LookupTransform_Response")


@pytest.mark.parametrize("name", sorted(n for n in MESSAGE_TYPES if n not in NOT_ROS2))
def test_every_zentf_type_round_trips_and_rosbags_reads_it(name: str, store) -> None:
    cls = MESSAGE_TYPES[name]
    msg = _example(cls)
    payload = encode(msg)
    assert payload[:4] == b"\x00\x01\x00\x00"
    back = decode(payload, name)
    if name == "turtlesim/msg/Pose" or name.startswith("turtlesim/srv"):  # float32 fields: compare rounded
        assert back.to_dict().keys() == msg.to_dict().keys()
    else:
        assert back == msg
    if name in store.fielddefs:  # rosbags' Jazzy store has no turtlesim, std_srvs nor service parts
        ref = _plain(store.deserialize_cdr(payload, name))
        assert ref == _lists(decode_plain(payload, name))
        ours = msg.to_dict()
        for key, value in ours.items():  # zentf's fields carry the same values in rosbags' reading
            assert _close(ref[key], value), (key, ref[key], value)


def _close(a, b) -> bool:
    if isinstance(a, dict) and isinstance(b, dict):
        return all(_close(a[k], b[k]) for k in b)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_close(x, y) for x, y in zip(a, b))
    if isinstance(a, float) or isinstance(b, float):
        return math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-7)
    return a == b


def test_marker_gets_the_ros_fields_zentf_does_not_model() -> None:
    payload = encode(_example(Marker))
    plain = decode_plain(payload, "visualization_msgs/msg/Marker")
    assert plain["mesh_resource"] == "" and plain["mesh_file"] == {"filename": "", "data": b""}
    assert plain["texture"]["format"] == "" and plain["uv_coordinates"] == []
    assert plain["text"] == "hi" and plain["points"][1] == {"x": 4.0, "y": 5.0, "z": 6.0}


# ---- bad input: one clear error, never a crash or a hang

def _one_tf() -> bytes:
    return encode_tf([TransformStamped(Header(Time(sec=1), "a"), "b", Transform())])


@pytest.mark.parametrize("payload,needle", [
    (b"", "shorter"), (b"\x00\x01\x00", "shorter"), (b"\x01\x07\x00\x00" + bytes(8), "encapsulation"),
])
def test_bad_headers_are_named(payload: bytes, needle: str) -> None:
    with pytest.raises(CdrError, match=needle):
        decode_plain(payload, TF)


def test_truncated_and_lying_payloads() -> None:
    good = _one_tf()
    for cut in range(4, len(good)):
        with pytest.raises(CdrError) as e:
            decode_plain(good[:cut], TF)
        assert "\n" not in str(e.value)
    huge = good[:4] + struct.pack("<I", 0xFFFFFFF0) + good[8:]
    with pytest.raises(CdrError, match="exceeds|cannot fit"):
        decode_plain(huge, TF)
    with pytest.raises(CdrError, match="claims"):
        tf_samples(huge)
    with pytest.raises(CdrError, match="little-endian"):
        tf_samples(b"\x00\x00\x00\x00" + good[4:])


def test_fast_path_keeps_good_elements_and_counts_bad_ones() -> None:
    a = TransformStamped(Header(Time(sec=1), "a"), "b", Transform())
    c = TransformStamped(Header(Time(sec=2), "a"), "c", Transform())
    payload = bytearray(encode_tf([a, c]))
    struct.pack_into("<i", payload, 8, -5)           # the first stamp's sec: negative
    samples, malformed, problem = tf_samples(bytes(payload))
    assert [s[1] for s in samples] == ["c"] and malformed == 1 and "bad stamp" in problem
    two = encode_tf([a, c])
    samples, malformed, problem = tf_samples(two[:-10])  # the second element is cut short
    assert [s[1] for s in samples] == ["b"] and malformed == 1 and "truncated" in problem
    bad_utf8 = bytearray(encode_tf([a]))
    bad_utf8[20] = 0xFF                                  # the frame id 'a' (after its length)
    samples, malformed, problem = tf_samples(bytes(bad_utf8))
    assert samples == [] and malformed == 1 and "UTF-8" in problem


def test_encoding_refuses_values_that_do_not_fit() -> None:
    with pytest.raises(CdrError, match="out of range|does not fit"):
        encode_tf([TransformStamped(Header(Time(sec=2**40), "a"), "b", Transform())])
    with pytest.raises(CdrError, match="not a TransformStamped"):
        encode_tf([{"header": {}}])
    with pytest.raises(CdrError, match="expected a string"):
        serialize({"frame_id": 3}, "std_msgs/msg/Header", definition)
    with pytest.raises(UnknownTypeError, match="nope"):
        decode_plain(_one_tf(), "nope/msg/Nope")


def test_many_transforms_per_message_take_the_learnt_layout_and_stay_exact() -> None:
    """Messages of >= 8 transforms are read through a cached layout; any change of frame names,
    lengths or bad values falls back to the careful loop: the result is always the generic decoder's."""
    def msg(names, base, x0):
        return [TransformStamped(Header(Time(nanoseconds=base + i), p), c, Transform(Vector3(x0 + i, -i, 0.5)))
                for i, (p, c) in enumerate(names)]

    names = [("world", f"frame_{j}" + "x" * (j % 5)) for j in range(30)]
    for base, x0, frames in ((10**18, 1.0, names), (10**18 + 5, 2.0, names),        # learn, then reuse
                             (3 * 10**17, 7.5, [(p, c.replace("frame", "FRAME")) for p, c in names]),  # same sizes
                             (10**9, 0.0, names[:29] + [("world", "other")]), (10**9, 0.0, names[::-1])):
        payload = encode_tf(msg(frames, base, x0))
        expected = [(t["header"]["frame_id"], t["child_frame_id"],
                     t["header"]["stamp"]["sec"] * 10**9 + t["header"]["stamp"]["nanosec"],
                     t["transform"]["translation"]["x"], t["transform"]["translation"]["y"],
                     t["transform"]["translation"]["z"], t["transform"]["rotation"]["x"],
                     t["transform"]["rotation"]["y"], t["transform"]["rotation"]["z"], t["transform"]["rotation"]["w"])
                    for t in decode_plain(payload, TF)["transforms"]]
        assert tf_samples(payload) == (expected, 0, None)
        assert tf_samples(payload) == (expected, 0, None)
    bad = bytearray(encode_tf(msg(names, 10**18, 1.0)))
    struct.pack_into("<i", bad, 8, -1)                  # first stamp negative: the careful loop names it
    samples, malformed, problem = tf_samples(bytes(bad))
    assert len(samples) == 29 and malformed == 1 and "bad stamp" in problem
