"""``bag convert`` and ``bag play`` of ROS bags write tf through the compiled TFMessage writers (tf_transcode.pyx):
the bytes the Python path writes (rosbags' decoder, to_plain, msgpack) for every fixture, for generated bags and
for damaged messages (which take the Python path and its log lines); bag play publishes the same values."""
from __future__ import annotations

import logging
import random
import threading

import pytest

from bag_generate import NS, _ts, transforms, write_ros1, write_ros2_mcap, write_rosbag2, write_zentf
from bag_reference import FIXTURES

pytest.importorskip("rosbags")

TF = "tf2_msgs/msg/TFMessage"


def _messages(path) -> list[tuple]:
    """Every message of a zentf bag, every field (the payload's bytes and, NaN-safe, its decoded values)."""
    from zentf.tools.bag import BagReader
    from zentf.transport.wire.codec import unpack

    return [(m.key, m.type_name, m.encoding, m.sender, m.latched, m.log_time, m.payload, repr(unpack(m.payload)))
            for m in BagReader(path)]


def _convert(src, dst, monkeypatch, compiled: bool) -> tuple[dict, list[tuple], list[str]]:
    """(convert's result, the output's messages, the TFMessage types rosbags decoded) with the compiled path on or off."""
    from zentf.tools.bag.convert import convert
    from zentf.tools.bag import source

    monkeypatch.setattr(source, "COMPILED_TF", compiled)
    through_python: list[str] = []
    real = source.Bag.decode

    def decode(self, m):
        if m.type_name == TF:
            through_python.append(m.topic)
        return real(self, m)

    monkeypatch.setattr(source.Bag, "decode", decode)
    result = convert(src, dst, to="zentf")
    monkeypatch.setattr(source.Bag, "decode", real)
    return result, _messages(dst), through_python


def _both(src, tmp_path, monkeypatch, caplog=None) -> tuple[list, list, list, list]:
    """(compiled output, reference output, TF messages the compiled run decoded in Python, log lines of each)."""
    logs = []
    outs = []
    python = []
    for compiled in (True, False):
        if caplog is not None:
            caplog.clear()
        with caplog.at_level(logging.DEBUG, logger="zentf.tools.bag") if caplog is not None else _nothing():
            result, msgs, through = _convert(src, tmp_path / f"out_{compiled}.mcap", monkeypatch, compiled)
        outs.append((result, msgs))
        python.append(through)
        logs.append([(r.levelname, r.getMessage()) for r in caplog.records] if caplog is not None else [])
    assert outs[0][0] == outs[1][0]  # messages written, problem, skipped topics
    return outs[0][1], outs[1][1], python[0], logs


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *a):
        return False


@pytest.mark.parametrize("name", list(FIXTURES))
def test_fixtures_convert_to_the_python_paths_bytes_through_the_compiled_writer(name, tmp_path, monkeypatch):
    fast, ref, through_python, _ = _both(FIXTURES[name], tmp_path, monkeypatch)
    assert fast == ref
    tf = [m for m in fast if m[1] == TF]
    assert len(tf) >= 518 and not through_python  # every TFMessage written in C


def _special(ros1: bool) -> list:
    """Records beyond transforms(): empty lists, long and unicode names, NaN/inf, odd stamps, > 16 elements."""
    nan, inf = float("nan"), float("inf")
    t = 100 * NS
    long = "L" * 300
    huge = "H" * 70_000
    rows = [
        ("/tf", "/a", t, []),
        ("/tf", "/a", t + 1, [("map", long, 50, 1, (1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0)),
                              (huge, "x" * 31, 50, 2, (1.0, 2.0, 3.0), (0.0, 0.0, 0.0, 1.0)),
                              ("y" * 32, "z" * 255, 50, 3, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)),
                              ("w" * 256, "v" * 65535, 50, 4, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))]),
        ("/tf", "/b", t + 2, [("ä/ü/日本", "🤖 robot", 60, 0, (-0.0, 1e308, 5e-324), (0.0, 0.0, 0.0, 1.0))]),
        ("/tf", "/b", t + 3, [("map", "nan", 61, 0, (nan, inf, -inf), (nan, 0.0, 0.0, 1.0))]),
        ("/tf", "/c", t + 4, [("map", f"many_{i}", 62, i, (i, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)) for i in range(20)]),
        ("/tf", "/c", t + 5, [("map", "stamps", 0, 0, (0.0,) * 3, (0.0, 0.0, 0.0, 1.0)),
                              ("map", "stamps", 2**31 - 1, 999_999_999, (0.0,) * 3, (0.0, 0.0, 0.0, 1.0)),
                              ("map", "stamps", 63, 1_500_000_000, (0.0,) * 3, (0.0, 0.0, 0.0, 1.0)),
                              ("map", "stamps", 127, 128, (0.0,) * 3, (0.0, 0.0, 0.0, 1.0)),
                              ("map", "stamps", 65535, 65536, (0.0,) * 3, (0.0, 0.0, 0.0, 1.0))]),
        # ROS 1: sec -1 is written as uint32 0xFFFFFFFF (2106); ROS 2: a negative sec (the Python path packs it)
        ("/tf", "/c", t + 6, [("map", "negative", -1, 5, (0.0,) * 3, (0.0, 0.0, 0.0, 1.0))]),
        ("/tf_static", "/static_pub", t + 7, [("base_link", "late_static", 0, 0, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))]),
    ]
    return rows


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    d = tmp_path_factory.mktemp("conv")
    recs = transforms(seed=5, messages=200, frames=20)
    out = {"ros2_mcap": write_rosbag2(d / "r2mcap", recs + _special(False), "mcap"),
           "ros2_sqlite": write_rosbag2(d / "r2db3", recs + _special(False), "sqlite3"),
           "ros2_mcap_chunks": write_ros2_mcap(d / "chunks.mcap", recs + _special(False)),
           "ros1": write_ros1(d / "r1.bag", recs + _special(True), "lz4"),
           "zentf": write_zentf(d / "z.mcap", recs + [r for r in _special(True) if "negative" not in repr(r)])}
    return out


@pytest.mark.parametrize("kind", ["ros2_mcap", "ros2_sqlite", "ros2_mcap_chunks", "ros1"])
def test_generated_bags_convert_to_the_python_paths_bytes(generated, kind, tmp_path, monkeypatch):
    """Many frames, static and dynamic, out-of-order stamps, empty lists, names of every msgpack str size,
    unicode, NaN/inf, -0.0, stamps at every int size and nanosec >= 1e9: byte for byte the Python path's."""
    fast, ref, through_python, _ = _both(generated[kind], tmp_path, monkeypatch)
    assert len(fast) == 201 + len(_special(False)) and fast == ref
    if kind == "ros1":
        assert not through_python
        negative = next(m for m in fast if "negative" in m[7])
        assert "'sec': 4294967295" in negative[7]  # ROS 1 time is unsigned, on both paths
    else:  # the negative sec and nanosec >= 1e9 are the compiled path's doubts: the Python path writes them
        assert len(through_python) == 2


def _mutated(payloads: list[bytes], seed: int) -> list[bytes]:
    rnd = random.Random(seed)
    out = []
    for p in payloads:
        b = bytearray(p)
        for _ in range(rnd.randrange(1, 4)):
            b[rnd.randrange(4, len(b))] = rnd.randrange(256)
        if rnd.random() < 0.3:
            b = b[:rnd.randrange(len(b) + 1)]
        out.append(bytes(b))
    return out


def _tf_payloads(ros1: bool, n: int, seed: int) -> list[bytes]:
    """n well-formed TFMessages serialized by rosbags (ROS 1 as the fixture bag defines it, or ROS 2 CDR)."""
    from rosbags.typesys import Stores, get_typestore

    rnd = random.Random(seed)
    store = _ros1_store() if ros1 else get_typestore(Stores.ROS2_HUMBLE)
    out = []
    for _ in range(n):
        items = [(rnd.choice(["map", "odom", "ä"]), rnd.choice(["base", "c" * rnd.randrange(1, 40)]),
                  rnd.randrange(0, 2**31), rnd.randrange(10**9), (rnd.random(), 0.0, 1.0), (0.0, 0.0, 0.0, 1.0))
                 for _ in range(rnd.randrange(1, 5))]
        msg = store.types[TF](transforms=[_ts(store, *it) for it in items])
        out.append(bytes(store.serialize_ros1(msg, TF) if ros1 else store.serialize_cdr(msg, TF)))
    return out


def _write_raw(path, payloads: list[bytes], ros1: bool):
    """A bag of these payloads (as they are) on /tf, written by rosbags (ROS 1) or the mcap package (ROS 2)."""
    if ros1:
        from rosbags.rosbag1 import Writer

        with Writer(path) as w:
            conn = w.add_connection("/tf", TF, typestore=_ros1_store(), callerid="/pub")
            for i, p in enumerate(payloads):
                w.write(conn, (i + 1) * NS, p)
        return path
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    msgdef, _ = get_typestore(Stores.ROS2_HUMBLE).generate_msgdef(TF, ros_version=2)
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=4096)
        w.start(profile="ros2", library="test")
        sid = w.register_schema(name=TF, encoding="ros2msg", data=msgdef.encode())
        ch = w.register_channel(topic="/tf", message_encoding="cdr", schema_id=sid)
        for i, p in enumerate(payloads):
            w.add_message(channel_id=ch, log_time=(i + 1) * NS, publish_time=(i + 1) * NS, sequence=i, data=p)
        w.finish()
    return path


def _ros1_store():
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from bag_reference import ROS1
    from zentf.tools.bag.ros1scan import Ros1Scan

    store = get_typestore(Stores.ROS1_NOETIC)
    scan = Ros1Scan(ROS1)
    scan.read_index()
    store.register(get_types_from_msg(next(c.msgdef for c in scan.connections.values() if c.topic == "/tf"), TF))
    return store


@pytest.mark.parametrize("ros1", [False, True], ids=["ros2_mcap", "ros1"])
def test_damaged_tf_messages_convert_as_the_python_path_converts_them(ros1, tmp_path, monkeypatch, caplog):
    """Bytes flipped, payloads cut short, bad lengths: the same messages written (or skipped) and the same lines."""
    good = _tf_payloads(ros1, 300, seed=9)
    payloads = [good[0]] + _mutated(good[1:], seed=13)
    path = _write_raw(tmp_path / ("d.bag" if ros1 else "d.mcap"), payloads, ros1)
    fast, ref, through_python, logs = _both(path, tmp_path, monkeypatch, caplog)
    assert fast == ref and logs[0] == logs[1]
    assert 30 < len(through_python) < 300  # the compiled path wrote the rest
    assert any("does not decode" in line for _, line in logs[0])


@pytest.mark.parametrize("ros1", [False, True], ids=["ros2_mcap", "ros1"])
def test_a_tf_topic_whose_first_message_is_damaged_is_skipped_in_one_line_as_before(ros1, tmp_path, monkeypatch, caplog):
    good = _tf_payloads(ros1, 5, seed=3)
    path = _write_raw(tmp_path / ("f.bag" if ros1 else "f.mcap"), [good[0][:30]] + good[1:], ros1)
    fast, ref, _, logs = _both(path, tmp_path, monkeypatch, caplog)
    assert fast == ref == [] and logs[0] == logs[1]
    assert [line for _, line in logs[0] if "cannot be carried" in line]


def test_a_bag_that_defines_tfmessage_otherwise_is_not_read_by_the_compiled_layout(tmp_path, monkeypatch):
    """TransformStamped with one more field: the walker would read its first fields and drop the rest; the
    bag's own definition (rosbags) is used instead, so the extra field is carried."""
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    msgdef, _ = get_typestore(Stores.ROS2_HUMBLE).generate_msgdef(TF, ros_version=2)
    odd = msgdef.replace("geometry_msgs/Transform transform\n", "geometry_msgs/Transform transform\nuint8 extra\n", 1)
    assert odd != msgdef
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(odd, TF))
    T = store.types
    ts = T["geometry_msgs/msg/TransformStamped"](
        header=T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=3, nanosec=4), frame_id="map"),
        child_frame_id="base", transform=T["geometry_msgs/msg/Transform"](
            translation=T["geometry_msgs/msg/Vector3"](x=1.0, y=2.0, z=3.0),
            rotation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)), extra=7)
    path = tmp_path / "odd.mcap"
    with open(path, "wb") as f:
        w = Writer(f)
        w.start(profile="ros2", library="test")
        sid = w.register_schema(name=TF, encoding="ros2msg", data=odd.encode())
        ch = w.register_channel(topic="/tf", message_encoding="cdr", schema_id=sid)
        w.add_message(channel_id=ch, log_time=NS, publish_time=NS, sequence=0,
                      data=store.serialize_cdr(T[TF](transforms=[ts]), TF))
        w.finish()
    fast, ref, through_python, _ = _both(path, tmp_path, monkeypatch)
    assert fast == ref and len(through_python) == 1 and "'extra': 7" in fast[0][7]


# ---------------------------------------------------------------- bag play


def _play(node_options, path, wire: str, monkeypatch, compiled: bool) -> tuple[list[tuple[str, bytes]], int]:
    """(key suffix, payload) of every tf message a Player publishes onto ``wire`` (a raw subscription of the
    player's own node: delivered in-process, none lost), and how many it wrote in C (to msgpack, to CDR)."""
    from zentf.tools.bag import source
    from zentf.tools.bag.playback import Player
    from zentf.transport.node import Node

    monkeypatch.setattr(source, "COMPILED_TF", compiled)
    got: list[tuple[str, bytes]] = []
    lock = threading.Lock()

    def on(sample):
        with lock:
            got.append(("tf_static" if "tf_static" in str(sample.key) else "tf", bytes(sample.payload)))

    with Node("player", options=node_options.with_(wire=wire)) as node:
        subs = [node.create_raw_subscription(t, on, type_name=TF) for t in ("tf", "tf_static")]
        player = Player(node, path, rate=1e6, namespace=node_options.namespace)
        stats = player.play()
        player.close()
        for s in subs:
            s.destroy()
    assert stats.messages > 0 and stats.problem is None
    return got, player.bag.compiled_tf + player.compiled_tf_to_cdr


def _values(wire: str, payload: bytes) -> str:
    """The decoded values of a played tf payload (NaN-safe)."""
    if wire == "ros2":
        from zentf.ros import decode_plain

        return repr(decode_plain(payload, TF))
    from zentf.transport.wire.codec import unpack

    return repr(unpack(payload))


@pytest.mark.parametrize("kind,wire", [("ros2_mcap", "zentf"), ("ros1", "zentf"), ("ros2_mcap", "ros2"), ("ros1", "ros2"),
                                       ("zentf", "ros2")])
def test_bag_play_publishes_the_python_paths_values(generated, kind, wire, node_options, monkeypatch):
    """On zentf's wire the same bytes; on ROS 2's wire a rosbag2 bag's tf goes out as recorded (what the
    compiled reader found well-formed), other bags' from msgpack to CDR in C: the same values either way."""
    from zentf.tools.bag import open_bag

    fast, compiled = _play(node_options, generated[kind], wire, monkeypatch, True)
    ref, _ = _play(node_options, generated[kind], wire, monkeypatch, False)
    assert compiled >= 200 and len(fast) == len(ref) >= 200
    # each topic in play order (a latched topic's publisher may deliver before or after the other's)
    by_topic = [{k: [_values(wire, p) for kk, p in got if kk == k] for k in ("tf", "tf_static")} for got in (fast, ref)]
    assert by_topic[0] == by_topic[1]
    if wire == "zentf":
        assert sorted(fast) == sorted(ref)
    elif kind == "ros2_mcap":  # the recorded CDR, untouched
        recorded = {m.payload for m in open_bag(generated[kind]).raw(["/tf", "/tf_static"])}
        assert sum(p in recorded for _, p in fast) >= compiled


# ---------------------------------------------------------------- Bag.tf() of ROS 1 bags


def _tf_rows(path, monkeypatch, compiled: bool) -> tuple[list, int]:
    """Bag.tf()'s (is_static, authority, rows) per message (NaN-safe), and how many rosbags decoded."""
    from zentf.tools.bag import open_bag, tfdecode

    monkeypatch.setattr(tfdecode, "COMPILED_ROS1", compiled)
    bag = open_bag(path)
    real = bag.ros.typestore.deserialize_ros1
    calls = []
    monkeypatch.setattr(bag.ros.typestore, "deserialize_ros1", lambda *a: calls.append(1) or real(*a))
    out = [(s, a, repr(rows)) for s, a, _raw, rows in bag.tf()]
    return out, len(calls)


@pytest.mark.parametrize("kind", ["fixture", "generated"])
def test_ros1_tf_rows_are_decoded_in_c_as_rosbags_decodes_them(generated, kind, monkeypatch):
    """tf doctor --bag's reader: the same rows (ROS 1 time unsigned on both paths), no rosbags decode."""
    path = FIXTURES["ros1_bag"] if kind == "fixture" else generated["ros1"]
    fast, python = _tf_rows(path, monkeypatch, True)
    ref, _ = _tf_rows(path, monkeypatch, False)
    assert fast == ref and len(fast) >= 200 and python == 0
    if kind == "generated":
        assert any(f"'negative', {0xFFFFFFFF * NS + 5}" in rows for _, _, rows in fast)


# ---------------------------------------------------------------- the DDS bridge's use of the same writer


def test_the_dds_bridges_tf_writer_gives_its_python_paths_bytes():
    """tf_cdr_to_msgpack (uint32 stamps, as zentf's broadcasters write) equals the bridge's Python writer byte for
    byte on nav2's tf and on random messages, and refuses (None) what that writer has to read element by element."""
    from zentf.tools.bag import open_bag
    from zentf.tools.dds.convert import _python_tf_cdr_to_msgpack
    from zentf.transport.ingest.tf_transcode import tf_cdr_to_msgpack

    real = [m.payload for m in open_bag(FIXTURES["nav2_mcap"]).raw(["/tf", "/tf_static"])]
    for payload in real + _tf_payloads(False, 300, seed=21):
        assert tf_cdr_to_msgpack(payload) == _python_tf_cdr_to_msgpack(payload)[0]
    for payload in _mutated(_tf_payloads(False, 300, seed=22), seed=23):
        got = tf_cdr_to_msgpack(payload)
        if got is not None:
            assert got == _python_tf_cdr_to_msgpack(payload)[0]


def test_zentf_tf_goes_to_cdr_in_c_as_the_python_path_writes_it():
    """tf_msgpack_to_cdr (bag play of zentf and ROS 1 bags onto ROS 2's wire) gives zentf.ros's encoder's bytes
    for what the Python path re-encodes (a zentf recording, odd layouts, mutated payloads), and None for what that
    path refuses."""
    from test_bag_load_compiled import _odd_zentf_payloads

    from zentf.core.messages import TFMessage
    from zentf.ros import codec as cdr_codec
    from zentf.tools.bag import open_bag
    from zentf.transport.ingest.tf_transcode import tf_msgpack_to_cdr
    from zentf.transport.wire import codec

    staged = [m.payload for m in open_bag(FIXTURES["nav2_mcap"].parent / "tf_doctor_staged.mcap").raw()
              if m.type_name == TF]
    written = 0
    for payload in staged + _odd_zentf_payloads():
        got = tf_msgpack_to_cdr(payload)
        try:
            want = cdr_codec.encode(codec.decode(payload, TFMessage), TF)
        except Exception:  # noqa: BLE001 - the Player's re-encoding refuses it (one line)
            want = None
        if got is not None:
            assert got == want
            written += 1
    assert written > len(staged) + 50
