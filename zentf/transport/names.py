"""ROS names (nodes, namespaces, topics) and their one-to-one mapping onto Zenoh key expressions."""
from __future__ import annotations

import re
from collections.abc import Mapping

__all__ = [
    "validate_node_name", "normalize_namespace", "expand_topic", "resolve_topic", "topic_to_key",
    "key_to_topic", "fully_qualified_node_name", "encode_chunk", "decode_chunk", "is_concrete_key",
]

_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")


def _check_tokens(what: str, original: str, tokens: list[str]) -> None:
    for tok in tokens:
        if not tok:
            raise ValueError(f"invalid {what} {original!r}: empty name part (doubled or trailing '/')")
        if not _TOKEN.match(tok):
            raise ValueError(f"invalid {what} {original!r}: part {tok!r} must be letters, digits and '_' "
                             "and must not start with a digit")


def validate_node_name(name: str) -> str:
    """A node name is one ROS token (no slashes); returns it unchanged."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"invalid node name {name!r}: must be a non-empty string")
    if not _TOKEN.match(name):
        raise ValueError(f"invalid node name {name!r}: use letters, digits and '_' (not starting with a digit)")
    return name


def normalize_namespace(namespace: str | None) -> str:
    """Namespace without leading/trailing slashes: None, '' and '/' all mean the root ('')."""
    if namespace is None:
        return ""
    if not isinstance(namespace, str):
        raise ValueError(f"invalid namespace {namespace!r}: must be a string")
    ns = namespace.strip()
    if ns.startswith("/"):
        ns = ns[1:]
    if ns.endswith("/"):
        ns = ns[:-1]
    if not ns:
        return ""
    _check_tokens("namespace", namespace, ns.split("/"))
    return ns


def fully_qualified_node_name(namespace: str, name: str) -> str:
    ns = normalize_namespace(namespace)
    return f"/{ns}/{name}" if ns else f"/{name}"


def expand_topic(topic: str, namespace: str = "", node_name: str | None = None) -> str:
    """Fully qualified topic ('/a/b'): relative names join the namespace, '~' the node's private space."""
    if not isinstance(topic, str) or not topic.strip():
        raise ValueError(f"invalid topic name {topic!r}: must be a non-empty string")
    t = topic.strip()
    ns = normalize_namespace(namespace)
    if t.startswith("~"):
        if node_name is None:
            raise ValueError(f"invalid topic name {topic!r}: '~' needs a node name")
        rest = t[1:]
        if rest and not rest.startswith("/"):
            raise ValueError(f"invalid topic name {topic!r}: '~' must be followed by '/'")
        t = fully_qualified_node_name(ns, node_name) + rest
    elif not t.startswith("/"):
        t = (f"/{ns}/" if ns else "/") + t
    body = t[1:]
    if body.endswith("/"):
        raise ValueError(f"invalid topic name {topic!r}: must not end with '/'")
    _check_tokens("topic name", topic, body.split("/"))
    return t


def resolve_topic(topic: str, namespace: str = "", node_name: str | None = None,
                  remappings: Mapping[str, str] | None = None) -> str:
    """Apply remappings (matched as written or fully qualified), then expand: ROS rules."""
    fq = expand_topic(topic, namespace, node_name)
    if remappings:
        target = remappings.get(topic)
        if target is None:
            for src, dst in remappings.items():
                try:
                    if expand_topic(src, namespace, node_name) == fq:
                        target = dst
                        break
                except ValueError:
                    continue
        if target is not None:
            fq = expand_topic(target, namespace, node_name)
    return fq


def topic_to_key(fq_topic: str) -> str:
    """'/robot1/tf' -> 'robot1/tf' (a relative name is expanded in the root namespace)."""
    return expand_topic(fq_topic)[1:]


def key_to_topic(key: str) -> str:
    return "/" + str(key)


def encode_chunk(text: str) -> str:
    """Squeeze a slash-separated name into one key chunk ('' -> '%', 'a/b' -> '%a%b')."""
    return "%" + text.strip("/").replace("/", "%") if text.strip("/") else "%"


def decode_chunk(chunk: str) -> str:
    return chunk[1:].replace("%", "/") if chunk.startswith("%") else chunk


def is_concrete_key(key: str) -> bool:
    """False for a key expression with wildcards (``**``, ``*``, ``t$*``): a put on one reaches every
    subscriber it intersects and arrives under that wildcard, so it is no topic's message (a receiver drops it)."""
    return "*" not in key
