"""TFMessage payloads of ROS bags -> rows for ``BufferCore.set_transforms_raw``.

This module is the one place that picks the CDR decoder for /tf and /tf_static: zentf's own CDR
codec (``zentf.ros``) when it provides a TFMessage decoder, else rosbags' generated deserializer.
ROS 1 payloads go through the compiled ROS 1 decoder when the bag defines TFMessage as ROS does, else
(and for anything that decoder doubts) through the bag's rosbags typestore.
"""
from __future__ import annotations

from collections.abc import Callable
from typing import Any

__all__ = ["TF_TYPE", "Row", "rows_of", "cdr_tf_decoder", "tf_decoder_for", "standard_tf_layout"]

TF_TYPE = "tf2_msgs/msg/TFMessage"
_NS = 1_000_000_000
#: ROS 1 TFMessages through the compiled decoder (tests switch it off for the reference)
COMPILED_ROS1 = True
#: (parent, child, stamp_ns, tx, ty, tz, qx, qy, qz, qw), what set_transforms_raw takes
Row = tuple[str, str, int, float, float, float, float, float, float, float]


def rows_of(msg: Any, ros1: bool = False) -> list[Row]:
    """Rows of a TFMessage decoded by rosbags (attribute access: header.stamp.sec ...). ROS 1 time is
    unsigned (rosbags reads its sec as int32: 0xFFFFFFFF would be -1 s, not 2106)."""
    out = []
    append = out.append
    mask = 0xFFFFFFFF if ros1 else -1
    for t in msg.transforms:
        h = t.header
        st = h.stamp
        tr = t.transform
        p = tr.translation
        q = tr.rotation
        append((h.frame_id, t.child_frame_id, (st.sec & mask) * _NS + st.nanosec, p.x, p.y, p.z, q.x, q.y, q.z,
                q.w))
    return out


def _fields_closure(store: Any, name: str) -> dict[str, Any]:
    from .ros import _closure

    return {k: v[1] for k, v in _closure(store, name).items()}


_STANDARD: dict[bool, dict[str, Any]] = {}


def _standard(ros1: bool) -> dict[str, Any]:
    """TFMessage's field definitions as ROS defines them (rosbags' Humble store; ROS 1's Header has a seq)."""
    if ros1 not in _STANDARD:
        from rosbags.interfaces import Nodetype
        from rosbags.typesys import Stores, get_typestore

        fields = _fields_closure(get_typestore(Stores.ROS2_HUMBLE), TF_TYPE)
        if ros1:
            header = fields["std_msgs/msg/Header"]
            fields["std_msgs/msg/Header"] = [("seq", (Nodetype.BASE, ("uint32", 0))), *header]
        _STANDARD[ros1] = fields
    return _STANDARD[ros1]


def standard_tf_layout(bag: Any) -> bool:
    """True if a RosBag's TFMessage (as its typestore has it: the bag's own definition, registered by
    ensure_type) is the one ROS defines, so the compiled readers' layout is the one rosbags would read."""
    try:
        return _fields_closure(bag.typestore, TF_TYPE) == _standard(bag.ros1)
    except (KeyError, IndexError, TypeError, AttributeError):
        return False


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
    """The TFMessage decoder for a RosBag: the CDR fast path for ROS 2; for ROS 1 the compiled decoder
    when the bag defines TFMessage as ROS does (looked up at the first message: the type is registered
    by then), its typestore otherwise and for what the compiled decoder doubts."""
    if not bag.ros1:
        return cdr_tf_decoder()[1]
    from zentf.transport.ingest.decoders import ros1_tf

    deser = bag.typestore.deserialize_ros1
    layout: list[bool] = []

    def decode(raw: bytes) -> list[Row]:
        if not layout:
            layout.append(COMPILED_ROS1 and standard_tf_layout(bag))
        rows = ros1_tf(raw) if layout[0] else None
        return rows if rows is not None else rows_of(deser(raw, TF_TYPE), True)
    return decode
