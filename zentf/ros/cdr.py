"""CDR (XCDR1, the OMG classic encoding ROS 2 uses) for any type with a .msg definition.

A payload starts with the 4-byte encapsulation header (``00 01 00 00``: CDR little-endian; ``00 00``
is big-endian, read but never written); every primitive is aligned to its size (8-byte types too, as
XCDR1 does) counted from the end of that header; strings are a uint32 length that counts the
terminating NUL, then the bytes and the NUL; sequences a uint32 count, then the elements; fixed arrays
only the elements. Values travel as plain data: dicts by field name, lists, ``bytes`` for
uint8/byte/char sequences. Padding bytes are not checked on read (real writers leave garbage there).
"""
from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

from .errors import CdrError, UnknownTypeError
from .msgdef import PRIMITIVES, Field, MsgDef

__all__ = ["ENCAPSULATION_LE", "MAX_SEQUENCE", "deserialize", "serialize", "default_value"]

ENCAPSULATION_LE = b"\x00\x01\x00\x00"
#: A sequence longer than this is refused (a corrupt length must not allocate gigabytes).
MAX_SEQUENCE = 16 * 1024 * 1024
_BYTES_BASES = ("uint8", "byte", "char")

Resolver = Callable[[str], MsgDef]


def _struct(endian: str, code: str, n: int = 1) -> struct.Struct:
    key = (endian, code, n)
    s = _STRUCTS.get(key)
    if s is None:
        s = _STRUCTS[key] = struct.Struct(f"{endian}{n if n != 1 else ''}{code}")
    return s


_STRUCTS: dict[tuple[str, str, int], struct.Struct] = {}


class _Reader:
    __slots__ = ("buf", "off", "end", "endian", "resolve")

    def __init__(self, buf: bytes, resolve: Resolver) -> None:
        if len(buf) < 4:
            raise CdrError(f"payload of {len(buf)} bytes is shorter than the CDR encapsulation header")
        kind = buf[1]
        if buf[0] != 0 or kind not in (0, 1):
            raise CdrError(f"unsupported CDR encapsulation {buf[:2].hex()} (expected 0001 or 0000)")
        self.endian = "<" if kind == 1 else ">"
        self.buf = buf
        self.off = 4
        self.end = len(buf)
        self.resolve = resolve

    def align(self, n: int) -> None:
        pad = (4 - self.off) % n  # alignment counts from the end of the 4-byte header
        self.off += pad

    def need(self, n: int, what: str) -> None:
        if self.off + n > self.end:
            raise CdrError(f"truncated payload: {what} needs {n} bytes at offset {self.off}, "
                           f"{max(0, self.end - self.off)} left")

    def prim(self, base: str, what: str) -> Any:
        code, size = PRIMITIVES[base]
        self.align(size)
        self.need(size, what)
        v = _struct(self.endian, code).unpack_from(self.buf, self.off)[0]
        self.off += size
        return v

    def count(self, what: str) -> int:
        n = self.prim("uint32", what)
        if n > MAX_SEQUENCE:
            raise CdrError(f"{what}: length {n} exceeds the {MAX_SEQUENCE} limit")
        return n

    def string(self, what: str) -> str:
        n = self.count(what)
        if n == 0:
            return ""
        self.need(n, what)
        raw = self.buf[self.off:self.off + n]
        self.off += n
        if raw[-1:] == b"\x00":
            raw = raw[:-1]
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError as e:
            raise CdrError(f"{what}: not UTF-8 ({e.reason} at byte {e.start})") from None

    def prim_array(self, base: str, n: int, what: str) -> Any:
        code, size = PRIMITIVES[base]
        if n == 0:
            return b"" if base in _BYTES_BASES else []
        self.align(size)
        self.need(n * size, what)
        if base in _BYTES_BASES:
            v: Any = bytes(self.buf[self.off:self.off + n])
        else:
            v = list(_struct(self.endian, code, n).unpack_from(self.buf, self.off))
        self.off += n * size
        return v

    def field(self, f: Field, path: str) -> Any:
        if f.array is None:
            return self.single(f.base, path)
        n = f.length if f.array == "fixed" else self.count(path)
        if f.array == "bounded" and n > f.length:
            raise CdrError(f"{path}: {n} elements exceed the bound {f.length}")
        if f.base in PRIMITIVES:
            return self.prim_array(f.base, n, path)
        if n > self.end - self.off:  # every element takes at least one byte
            raise CdrError(f"{path}: {n} elements cannot fit in {self.end - self.off} bytes")
        return [self.single(f.base, f"{path}[{i}]") for i in range(n)]

    def single(self, base: str, path: str) -> Any:
        if base in PRIMITIVES:
            return self.prim(base, path)
        if base == "string":
            return self.string(path)
        return self.struct(self.resolve(base), path)

    def struct(self, d: MsgDef, path: str) -> dict:
        if not d.fields:
            self.prim("uint8", path)  # the dummy member of an empty message
            return {}
        return {f.name: self.field(f, f"{path}.{f.name}" if path else f.name) for f in d.fields}


def deserialize(payload: bytes | bytearray | memoryview, type_name: str, resolve: Resolver) -> dict:
    """CDR bytes (with encapsulation header) -> plain dict; CdrError says what and where."""
    r = _Reader(bytes(payload), resolve)
    try:
        return r.struct(resolve(type_name), "")
    except (UnknownTypeError, KeyError) as e:
        raise UnknownTypeError(str(e)) from None
    except struct.error as e:  # pragma: no cover - need() runs first
        raise CdrError(f"malformed payload: {e}") from None


class _Writer:
    __slots__ = ("out", "resolve")

    def __init__(self, resolve: Resolver) -> None:
        self.out = bytearray(ENCAPSULATION_LE)
        self.resolve = resolve

    def align(self, n: int) -> None:
        pad = (4 - len(self.out)) % n
        if pad:
            self.out += b"\x00" * pad

    def prim(self, base: str, v: Any, path: str) -> None:
        code, size = PRIMITIVES[base]
        self.align(size)
        try:
            self.out += _struct("<", code).pack(v)
        except struct.error as e:
            raise CdrError(f"{path}: {v!r} does not fit {base} ({e})") from None

    def string(self, v: Any, path: str) -> None:
        if not isinstance(v, str):
            raise CdrError(f"{path}: expected a string, got {type(v).__name__}")
        raw = v.encode("utf-8")
        self.prim("uint32", len(raw) + 1, path)
        self.out += raw
        self.out += b"\x00"

    def field(self, f: Field, v: Any, path: str) -> None:
        if f.array is None:
            self.single(f.base, v, path)
            return
        if f.base in _BYTES_BASES and isinstance(v, (bytes, bytearray, memoryview)):
            items: Any = bytes(v)
        elif isinstance(v, (list, tuple)):
            items = v
        elif hasattr(v, "tolist"):  # numpy arrays
            items = v.tolist()
        else:
            raise CdrError(f"{path}: expected a list, got {type(v).__name__}")
        n = len(items)
        if f.array == "fixed":
            if n != f.length:
                raise CdrError(f"{path}: expected {f.length} elements, got {n}")
        else:
            if f.array == "bounded" and n > f.length:
                raise CdrError(f"{path}: {n} elements exceed the bound {f.length}")
            self.prim("uint32", n, path)
        if f.base in PRIMITIVES:
            if n == 0:
                return
            code, size = PRIMITIVES[f.base]
            self.align(size)
            if isinstance(items, bytes):
                self.out += items
                return
            try:
                self.out += _struct("<", code, n).pack(*items)
            except struct.error as e:
                raise CdrError(f"{path}: values do not fit {f.base}[] ({e})") from None
            return
        for i, item in enumerate(items):
            self.single(f.base, item, f"{path}[{i}]")

    def single(self, base: str, v: Any, path: str) -> None:
        if base in PRIMITIVES:
            self.prim(base, v, path)
        elif base == "string":
            self.string(v, path)
        else:
            self.struct(self.resolve(base), v, path)

    def struct(self, d: MsgDef, v: Any, path: str) -> None:
        if not d.fields:
            self.prim("uint8", 0, path)
            return
        if hasattr(v, "to_dict") and not isinstance(v, dict):
            v = v.to_dict()
        if not isinstance(v, dict):
            raise CdrError(f"{path or d.name}: expected a {d.name} dict, got {type(v).__name__}")
        for f in d.fields:
            sub = f"{path}.{f.name}" if path else f.name
            if f.name in v:
                self.field(f, v[f.name], sub)
            else:
                self.field(f, default_value(f, self.resolve), sub)


def serialize(value: Any, type_name: str, resolve: Resolver) -> bytes:
    """Plain dict (or an object with ``to_dict``) -> CDR little-endian bytes with the header.

    Missing fields take their ROS defaults (0, '', empty sequences), so a zentf dataclass with fewer
    fields than the ROS type still yields a complete ROS message.
    """
    w = _Writer(resolve)
    try:
        w.struct(resolve(type_name), value, "")
    except KeyError as e:
        raise UnknownTypeError(str(e.args[0]) if e.args else "unknown type") from None
    return bytes(w.out)


def default_value(f: Field, resolve: Resolver) -> Any:
    """The ROS default of a field (zeros, '', empty sequences, fixed arrays filled)."""
    def one(base: str) -> Any:
        if base in PRIMITIVES:
            return False if base == "bool" else (0.0 if base.startswith("float") else 0)
        if base == "string":
            return ""
        d = resolve(base)
        return {g.name: default_value(g, resolve) for g in d.fields}

    if f.array is None:
        return one(f.base)
    if f.array == "fixed":
        if f.base in _BYTES_BASES:
            return bytes(f.length)
        return [one(f.base) for _ in range(f.length)]
    return b"" if f.base in _BYTES_BASES else []
