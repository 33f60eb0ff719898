"""The drones demo recording, computed from its closed-form model (no Zenoh needed)."""
from __future__ import annotations

import os
from typing import Any

from .info import bag_info
from .native import BagWriter

__all__ = ["write_drones_demo"]

_NS = 1_000_000_000


def write_drones_demo(path: str | os.PathLike, duration: float = 10.0, *, tf_rate: float = 50.0,
                      marker_rate: float = 5.0, trail_length: int = 50, start: float = 1_700_000_000.0) -> dict[str, Any]:
    """A recording of the drones demo, computed from its closed-form model (same messages, same topics).

    tf at ``tf_rate`` (av1, av2 in world, stamped t), ``visual_markers`` trails at ``marker_rate``
    (as plots_publisher draws them) and a latched tf_static ``world -> ground``; root namespace.
    """
    from zentf.demos.frames_publisher import av2_in_av1, drone_poses
    from zentf.transport.wire import codec as wire
    from zentf.core.messages import (ColorRGBA, Header, Marker, MarkerArray, Point, Quaternion, TFMessage, Transform,
                                TransformStamped, Vector3)
    from zentf.core.time import Time

    def tf_msg(t_ns: int, poses: list) -> bytes:
        stamp = Time(nanoseconds=t_ns)
        return wire.encode_tf([TransformStamped(header=Header(stamp=stamp, frame_id=p), child_frame_id=c,
                                                transform=Transform(Vector3(*tr), Quaternion(*q)))
                               for p, c, tr, q in poses])

    tf_enc = f"application/msgpack;{TFMessage.TYPE_NAME}"
    mk_enc = f"application/msgpack;{MarkerArray.TYPE_NAME}"
    colors = ((1.0, 0.2, 0.2, 1.0), (0.2, 0.4, 1.0, 1.0), (0.2, 0.9, 0.2, 1.0))
    names = (("world", "av1"), ("world", "av2"), ("av1", "av2"))
    trails: list[list[Point]] = [[], [], []]
    t0 = int(start * _NS)
    n_tf = int(duration * tf_rate) + 1
    tf_step = int(_NS / tf_rate)
    mk_every = max(1, round(tf_rate / marker_rate))
    with BagWriter(path, chunk_size=16 * 1024) as w:
        w.write("tf_static", tf_msg(t0, [("world", "ground", (0.0, 0.0, -0.5), (0.0, 0.0, 0.0, 1.0))]),
                tf_enc, "/demo_static", t0)
        for i in range(n_tf):
            t_ns = t0 + i * tf_step
            ts = t_ns / _NS
            poses = drone_poses(ts)
            w.write("tf", tf_msg(t_ns, poses), tf_enc, "/frames_publisher", t_ns + 200_000)
            if i % mk_every:
                continue
            rel = av2_in_av1(ts)
            pts = [poses[0][2], poses[1][2], rel]
            markers = []
            for k in range(3):
                trails[k].append(Point(*pts[k]))
                del trails[k][:-trail_length]
                markers.append(Marker(header=Header(stamp=Time(nanoseconds=t_ns), frame_id=names[k][0]), ns="trails",
                                      id=k, type=Marker.LINE_STRIP, action=Marker.ADD, scale=Vector3(0.02, 0.0, 0.0),
                                      color=ColorRGBA(*colors[k]), points=list(trails[k]),
                                      text=f"{names[k][1]} in {names[k][0]}"))
            w.write("visual_markers", wire.encode(MarkerArray(markers=markers)), mk_enc, "/plots_publisher",
                    t_ns + 500_000)
    return bag_info(path)
