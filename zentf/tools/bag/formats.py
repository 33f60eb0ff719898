"""Which recording a path holds: ROS 1 .bag, rosbag2 (folder, .db3, .mcap) or zentf's own MCAP.

Detection reads magic bytes (and, for MCAP, the header's profile and the channels' message
encoding), never the file name alone; anything else is refused naming what was found.
"""
from __future__ import annotations

import enum
import os
import struct
from pathlib import Path

from .errors import BagError, UnknownFormatError

__all__ = ["BagFormat", "detect_format", "storage_file"]

MCAP_MAGIC = b"\x89MCAP0\r\n"
ROS1_MAGIC = b"#ROSBAG V2.0\n"
SQLITE_MAGIC = b"SQLite format 3\x00"


class BagFormat(enum.Enum):
    """The formats zentf reads; the value is what ``bag info`` prints."""

    ZENTF = "zentf MCAP (msgpack payloads)"
    ROS1 = "ROS 1 bag (ROS 1 serialization)"
    ROS2_MCAP = "ROS 2 rosbag2 MCAP (CDR payloads)"
    ROS2_SQLITE = "ROS 2 rosbag2 SQLite3 (CDR payloads)"

    @property
    def is_ros(self) -> bool:
        return self is not BagFormat.ZENTF

    @property
    def encoding(self) -> str:
        return {"ZENTF": "msgpack", "ROS1": "ros1", "ROS2_MCAP": "cdr", "ROS2_SQLITE": "cdr"}[self.name]


_KNOWN_MAGICS = ((b"\x89PNG", "a PNG image"), (b"PK\x03\x04", "a zip archive"), (b"\x1f\x8b", "gzip data"),
                 (b"%PDF", "a PDF document"), (b"\x7fELF", "an ELF executable"), (b"BZh", "bzip2 data"),
                 (b"\x28\xb5\x2f\xfd", "zstd data"), (b"#ROSBAG V1", "a ROS 1 bag of the old 1.x format"),
                 (b"\xff\xd8\xff", "a JPEG image"))


def _describe(head: bytes, size: int) -> str:
    """What a file looks like, for the error naming it."""
    if size == 0:
        return "an empty file"
    for magic, what in _KNOWN_MAGICS:
        if head.startswith(magic):
            return what
    try:
        text = head.decode("utf-8")
    except UnicodeDecodeError:
        return f"{size} bytes of binary data starting {head[:8].hex(' ')}"
    first = text.strip().splitlines()[0][:40] if text.strip() else ""
    return f"a text file starting {first!r}" if first else "a blank text file"


def storage_file(folder: Path) -> Path | None:
    """The single .db3/.mcap of a rosbag2 folder that lacks metadata.yaml; None if not exactly one."""
    found = sorted(p for p in folder.iterdir() if p.suffix in (".db3", ".mcap"))
    return found[0] if len(found) == 1 else None


def _mcap_kind(path: Path) -> BagFormat:
    """zentf or ROS 2 MCAP, from the header's profile (then the first channel's message encoding)."""
    with open(path, "rb") as f:
        f.seek(8)
        head = f.read(1 + 8 + 4 + 256)
    if len(head) >= 13 and head[0] == 0x01:
        (n,) = struct.unpack_from("<I", head, 9)
        profile = head[13:13 + n]
        if profile == b"ros2":
            return BagFormat.ROS2_MCAP
        if profile == b"zentf":
            return BagFormat.ZENTF
    # unknown or empty profile: decide by the payload encoding of the channels
    with open(path, "rb") as f:
        data = f.read(1 << 20)
    return BagFormat.ROS2_MCAP if b"\x03\x00\x00\x00cdr" in data else BagFormat.ZENTF


def detect_format(path: str | os.PathLike) -> tuple[BagFormat, Path]:
    """(format, path to open): a rosbag2 folder without metadata.yaml resolves to its one storage file, a
    rosbag2 ``metadata.yaml`` to its folder."""
    p = Path(path)
    if p.name == "metadata.yaml" and p.is_file():  # ros2 bag tools take a bag's metadata for its folder
        p = p.parent
    if p.is_dir():
        if (p / "metadata.yaml").is_file():
            import yaml

            from ...core import safe_yaml

            try:
                meta = safe_yaml.load_file(p / "metadata.yaml") or {}
                storage = str(meta["rosbag2_bagfile_information"].get("storage_identifier", ""))
            except safe_yaml.YamlRefused as e:
                raise BagError(f"{p}/metadata.yaml: {e}") from None
            except (OSError, UnicodeDecodeError, yaml.YAMLError, KeyError, TypeError, AttributeError) as e:
                raise BagError(f"{p}: unreadable metadata.yaml ({type(e).__name__})") from None
            return (BagFormat.ROS2_MCAP if storage == "mcap" else BagFormat.ROS2_SQLITE), p
        one = storage_file(p)
        if one is None:
            names = ", ".join(sorted(x.name for x in p.iterdir())[:5]) or "nothing"
            raise UnknownFormatError(f"{p}: a folder without metadata.yaml or a single .db3/.mcap file (found: {names})")
        return detect_format(one)[0], one
    try:
        size = p.stat().st_size
        with open(p, "rb") as f:
            head = f.read(64)
    except OSError as e:
        raise BagError(f"cannot read {p}: {e.strerror}") from None
    if head.startswith(MCAP_MAGIC):
        return _mcap_kind(p), p
    if head.startswith(ROS1_MAGIC):
        return BagFormat.ROS1, p
    if head.startswith(SQLITE_MAGIC):
        return BagFormat.ROS2_SQLITE, p
    raise UnknownFormatError(f"{p} is not a bag: found {_describe(head, size)} "
                             "(zentf reads ROS 1 .bag, rosbag2 .db3/.mcap and zentf .mcap)")
