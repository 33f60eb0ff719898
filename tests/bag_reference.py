"""Reference side of the bag tests: decode a bag with rosbags (independent of zentf's readers) and insert
its transforms sample by sample, as a user without zentf's bag tools would."""
from __future__ import annotations

from pathlib import Path

DATA = Path(__file__).resolve().parent / "data" / "ros_bags"
NAV2 = DATA.parent / "nav2_turtlebot.mcap"  # shared with the CDR codec tests
ROS1 = DATA / "tf_example.bag"
ROS2_DIR = DATA / "tf_example"
ROS2_DB3 = DATA / "tf_example" / "tf_example.db3"
FIXTURES = {"nav2_mcap": NAV2, "ros1_bag": ROS1, "ros2_folder": ROS2_DIR, "ros2_db3": ROS2_DB3}
#: (target, source) pairs looked up in each fixture
PAIRS = {
    "nav2": [("map", "oakd_rgb_camera_optical_frame"), ("odom", "base_link"), ("map", "base_link"),
             ("base_link", "left_wheel"), ("odom", "oakd_imu_frame"), ("base_footprint", "map")],
    "tf_example": [("odom", "base_link"), ("odom", "base_footprint"), ("base_link", "odom")],
}


def pairs_for(path: Path) -> list[tuple[str, str]]:
    return PAIRS["nav2" if "nav2" in path.name else "tf_example"]


def rosbags_transforms(path: Path) -> list[tuple[str, str, str, int, tuple, tuple]]:
    """(topic, parent, child, stamp_ns, translation, rotation) of every /tf and /tf_static transform."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    out = []
    with AnyReader([path], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
        conns = [c for c in reader.connections if c.topic in ("/tf", "/tf_static")]
        for conn, _, raw in reader.messages(connections=conns):
            msg = reader.deserialize(raw, conn.msgtype)
            for t in msg.transforms:
                v, q = t.transform.translation, t.transform.rotation
                out.append((conn.topic, t.header.frame_id, t.child_frame_id,
                            t.header.stamp.sec * 1_000_000_000 + t.header.stamp.nanosec,
                            (v.x, v.y, v.z), (q.x, q.y, q.z, q.w)))
    return out


def reference_core(path: Path):
    """A BufferCore filled sample by sample from rosbags' decode (cache large enough for any bag)."""
    from zentf.core.buffer_core import BufferCore

    core = BufferCore(cache_time=1e7)
    for topic, parent, child, stamp, tr, rot in rosbags_transforms(path):
        core.set_transform_raw(parent, child, stamp, *tr, *rot, "rosbags", topic == "/tf_static")
    return core
