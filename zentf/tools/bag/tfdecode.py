"""TFMessage payloads of ROS bags -> rows for ``BufferCore.set_transforms_raw``.

This module is the one place that picks the CDR decoder for /tf and /tf_static: zentf's own CDR
codec (``zentf.ros``) when it provides a TFMessage decoder, else rosbags' generated deserializer.
ROS 1 payloads always go through the bag's rosbags typestore.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["TF_TYPE", "Row", "rows_of", "cdr_tf_decoder", "tf_decoder_for"]

TF_TYPE = "tf2_msgs/msg/TFMessage"
_NS = 1_000_000_000
#: (parent, child, stamp_ns, tx, ty, tz, qx, qy, qz, qw), what set_transforms_raw takes
Row = tuple[str, str, int, float, float, float, float, float, float, float]


def rows_of(msg: Any) -> list[Row]:
    """Rows of a TFMessage decoded by rosbags (attribute access: header.stamp.sec ...)."""
    out = []
    append = out.append
    for t in msg.transforms:
        h = t.header
        st = h.stamp
        tr = t.transform
        p = tr.translation
        q = tr.rotation
        append((h.frame_id, t.child_frame_id, st.sec * _NS + st.nanosec, p.x, p.y, p.z, q.x, q.y, q.z, q.w))
    return out


def _zentf_codec() -> Callable[[bytes], list[Row]] | None:
    """zentf's TFMessage decoder: compiled (zentf/transport/ingest/decoders.pyx) for a well-formed payload, else zentf.ros'
    hand-laid one (elements it refuses are dropped, as the buffer would)."""
    try:
        from zentf.ros.tf import tf_samples
    except ImportError:  # pragma: no cover - zentf.ros ships with zentf; kept so this stays one switch
        return None
    from zentf.transport.ingest.decoders import cdr_tf

    def decode(raw: bytes) -> list[Row]:
        rows = cdr_tf(raw)  # None: anything doubtful, read again below
        return rows if rows is not None else tf_samples(raw)[0]
    return decode


def cdr_tf_decoder() -> tuple[str, Callable[[bytes], list[Row]]]:
    """(name, decoder) of the fastest CDR TFMessage decoder available."""
    fast = _zentf_codec()
    if fast is not None:
        return "zentf.ros", fast
    from rosbags.typesys import Stores, get_typestore

    deser = get_typestore(Stores.ROS2_HUMBLE).deserialize_cdr
    return "rosbags", lambda raw: rows_of(deser(raw, TF_TYPE))


def tf_decoder_for(bag: Any) -> Callable[[bytes], list[Row]]:
    """The TFMessage decoder for a RosBag: the CDR fast path for ROS 2, its typestore for ROS 1."""
    if not bag.ros1:
        return cdr_tf_decoder()[1]
    deser = bag.typestore.deserialize_ros1
    return lambda raw: rows_of(deser(raw, TF_TYPE))
