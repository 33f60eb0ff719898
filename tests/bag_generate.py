"""Bags written by independent writers (rosbags, mcap, zentf's BagWriter) for the loader tests, and dumps of a
buffer's every sample (bit for bit) to compare two loads."""
from __future__ import annotations

import random
import struct
from pathlib import Path

NS = 1_000_000_000


def dump(buf, authorities: bool = True) -> dict:
    """Every frame's samples, bit for bit: statics (parent, values), dynamics (stamps, parents, values bytes)."""
    out = {}
    for fid, name in enumerate(buf._names):
        c = buf._caches[fid]
        if c is None:
            continue
        auth = buf._auths[fid] if authorities else None
        if getattr(c, "is_static", False):
            parent, *values = c.sample
            out[name] = ("static", buf._names[parent], struct.pack("<7d", *values), auth)
        else:
            st, par, d = c.columns()
            out[name] = ("dynamic", st.tobytes(), tuple(buf._names[p] for p in par), d.tobytes(), auth)
    return out


def sample_by_sample(path):
    """The uncompiled load: Bag.tf()'s Python decoders, rows inserted in file order."""
    from zentf import Buffer
    from zentf.core.time import Duration
    from zentf.tools.bag import open_bag
    from zentf.transport.wire.codec import ingest_tf

    bag = open_bag(path)
    buf = Buffer(cache_time=Duration(nanoseconds=1 << 62))
    for is_static, authority, payload, rows in bag.tf():
        if rows is None:
            try:
                ingest_tf(payload, buf, authority, is_static)
            except ValueError:
                pass
        elif rows:
            buf.set_transforms_raw(rows, authority, is_static)
    return buf


def transforms(seed: int, messages: int = 1500, frames: int = 60):
    """(topic, callerid, log_time, [(parent, child, sec, nsec, xyz, xyzw)]) of a generated recording: a
    chain and a star of dynamic frames, static leaves, stamps out of order and repeated, three publishers
    and a frame whose parent changes."""
    rnd = random.Random(seed)
    out = []
    statics = [("base_link", f"sensor_{i}", 5, 0, (0.1 * i, 0.0, 0.2), (0.0, 0.0, 0.0, 1.0)) for i in range(10)]
    out.append(("/tf_static", "/static_pub", 4 * NS, statics))
    dyn = ["odom"] + [f"link_{i}" for i in range(frames)]
    t0 = 10 * NS
    for k in range(messages):
        log_time = t0 + k * 10_000_000
        items = []
        for j in range(rnd.randint(1, 12)):
            i = rnd.randrange(frames)
            parent = dyn[i] if i % 7 else "odom"
            if i == 3 and k > messages // 2:
                parent = "base_link"  # re-parented half way
            stamp = log_time + rnd.choice((0, 0, 0, -rnd.randrange(0, 300_000_000), 5_000_000))
            q = [rnd.uniform(-1, 1) for _ in range(4)]
            n = sum(v * v for v in q) ** 0.5
            items.append((parent, dyn[i + 1], stamp // NS, stamp % NS,
                          (rnd.uniform(-5, 5), rnd.uniform(-5, 5), rnd.random()), tuple(v / n for v in q)))
        items.append(("odom", "base_link", log_time // NS, log_time % NS, (k * 0.01, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)))
        out.append(("/tf", ("/a", "/b", "/c")[k % 3], log_time, items))
    return out


def _ts(store, parent, child, sec, nsec, xyz, q):
    T = store.types
    seq = {"seq": 0} if any(n == "seq" for n, _ in store.fielddefs["std_msgs/msg/Header"][1]) else {}
    return T["geometry_msgs/msg/TransformStamped"](
        header=T["std_msgs/msg/Header"](**seq, stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nsec),
                                        frame_id=parent),
        child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](translation=T["geometry_msgs/msg/Vector3"](x=xyz[0], y=xyz[1], z=xyz[2]),
                                                   rotation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])))


def write_rosbag2(path: Path, records, storage: str = "mcap") -> Path:
    """A rosbag2 folder (MCAP or SQLite storage) written by rosbags."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    with Writer(path, version=8, storage_plugin=plugin) as w:
        conns = {}
        for topic, _, t, items in records:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, "tf2_msgs/msg/TFMessage", typestore=store)
            msg = store.types["tf2_msgs/msg/TFMessage"](transforms=[_ts(store, *it) for it in items])
            w.write(conns[topic], t, store.serialize_cdr(msg, "tf2_msgs/msg/TFMessage"))
    return path


def write_ros1(path: Path, records, compression: str = "lz4", chunk: int = 16 * 1024) -> Path:
    """A ROS 1 bag written by rosbags (several chunks, callerids, latched tf_static)."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    from bag_reference import ROS1
    from zentf.tools.bag.ros1scan import Ros1Scan

    store = get_typestore(Stores.ROS1_NOETIC)  # + tf2_msgs/TFMessage as the fixture bag defines it
    scan = Ros1Scan(ROS1)
    scan.read_index()
    msgdef = next(c.msgdef for c in scan.connections.values() if c.topic == "/tf")
    store.register(get_types_from_msg(msgdef, "tf2_msgs/msg/TFMessage"))
    w = Writer(path)
    if compression != "none":
        w.set_compression({"lz4": Writer.CompressionFormat.LZ4, "bz2": Writer.CompressionFormat.BZ2}[compression])
    w.chunk_threshold = chunk
    with w:
        conns = {}
        for topic, caller, t, items in records:
            if (topic, caller) not in conns:
                conns[(topic, caller)] = w.add_connection(topic, "tf2_msgs/msg/TFMessage", typestore=store,
                                                          callerid=caller, latching=int(topic == "/tf_static"))
            msg = store.types["tf2_msgs/msg/TFMessage"](transforms=[_ts(store, *it) for it in items])
            w.write(conns[(topic, caller)], t, store.serialize_ros1(msg, "tf2_msgs/msg/TFMessage"))
    return path


def write_zentf(path: Path, records) -> Path:
    """A zentf MCAP written by BagWriter (msgpack payloads, the sender as the authority)."""
    from zentf.transport.wire import codec as wire
    from zentf.tools.bag import BagWriter

    with BagWriter(path, chunk_size=16 * 1024) as w:
        for topic, caller, t, items in records:
            payload = wire.encode_tf([{"header": {"stamp": {"sec": s, "nanosec": ns}, "frame_id": p},
                                       "child_frame_id": c,
                                       "transform": {"translation": dict(zip("xyz", xyz)), "rotation": dict(zip("xyzw", q))}}
                                      for p, c, s, ns, xyz, q in items])
            w.write(topic.strip("/"), payload, "application/msgpack;tf2_msgs/msg/TFMessage", caller, t)
    return path


def write_ros2_mcap(path: Path, records, chunk_size: int = 16 * 1024) -> Path:
    """A ROS 2 MCAP file written by the mcap package (small zstd chunks), payloads by rosbags."""
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    msgdef, _ = store.generate_msgdef("tf2_msgs/msg/TFMessage", ros_version=2)
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=chunk_size)
        w.start(profile="ros2", library="test")
        sid = w.register_schema(name="tf2_msgs/msg/TFMessage", encoding="ros2msg", data=msgdef.encode())
        chans = {}
        for topic, _, t, items in records:
            if topic not in chans:
                chans[topic] = w.register_channel(topic=topic, message_encoding="cdr", schema_id=sid)
            msg = store.types["tf2_msgs/msg/TFMessage"](transforms=[_ts(store, *it) for it in items])
            w.add_message(channel_id=chans[topic], log_time=t, publish_time=t, sequence=0,
                          data=store.serialize_cdr(msg, "tf2_msgs/msg/TFMessage"))
        w.finish()
    return path
