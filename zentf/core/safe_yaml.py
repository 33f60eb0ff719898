"""YAML read as plain data, bounded: the one loader of every YAML zentf reads from a user or a file.

Command-line data (``topic pub``, ``service call``, ``param set``, ``-p name:=value``), params files,
launch files and bag metadata are all YAML, and YAML has three features that turn a few hundred bytes
into unbounded work: aliases (``*a``; nine levels of nine are the "billion laughs", 9^9 values once
walked), the anchors they point to (``&a``), and tags (``!!python/...``, ``!!binary``, ``!!set``:
constructors beyond plain data). None of it is needed to write data out, so all three are refused,
before anything is built, with one line saying where; a document over ``limit`` characters or nested
deeper than MAX_DEPTH is refused too. What is left (mappings, lists, strings, numbers, booleans,
null) is built by PyYAML's safe loader, the C one when present.
"""
from __future__ import annotations

from typing import Any

import yaml

__all__ = ["YamlRefused", "check", "load", "load_file", "MAX_CHARS", "MAX_DEPTH"]

#: Largest YAML document read (characters); the callers reading short command-line values pass less.
MAX_CHARS = 16 * 1024 * 1024
#: Deepest nesting of lists and mappings.
MAX_DEPTH = 64

_Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class YamlRefused(ValueError):
    """YAML zentf will not read: ``problem`` says why, ``line`` (1-based) where, when known."""

    def __init__(self, problem: str, line: int | None = None) -> None:
        self.problem, self.line = problem, line
        super().__init__(f"{problem} (line {line})" if line else problem)


def check(text: str, *, limit: int = MAX_CHARS, context: str = "") -> None:
    """Refuse ``text`` when it is longer than ``limit`` characters, nests deeper than MAX_DEPTH, or has
    an alias, an anchor or a tag (YamlRefused; ``context`` follows "is not allowed", e.g. " in a launch
    file"); malformed YAML raises PyYAML's own error, as loading it would. Reads events only: nothing
    is built, so this costs one pass of the parser whatever the document holds."""
    if len(text) > limit:
        raise YamlRefused(f"YAML of {len(text)} characters is over the {limit}-character limit")
    loader = _Loader(text)
    anchor: tuple[str, int] | None = None
    depth = 0
    try:
        while loader.check_event():
            event = loader.get_event()
            line = event.start_mark.line + 1
            if isinstance(event, yaml.AliasEvent):
                raise YamlRefused(f"YAML alias *{event.anchor} is not allowed{context} "
                                  "(aliases can expand without bound; write the value out)", line)
            if isinstance(event, yaml.NodeEvent):
                if event.anchor is not None and anchor is None:
                    anchor = (event.anchor, line)
                tag = getattr(event, "tag", None)
                if tag is not None and not (isinstance(event, yaml.ScalarEvent) and tag == "!"
                                            and event.implicit[1]):  # ('!' = a quoted scalar's own tag)
                    shown = tag.replace("tag:yaml.org,2002:", "!!")
                    raise YamlRefused(f"YAML tag {shown[:60]} is not allowed{context} "
                                      "(plain data only; write the value without it)", line)
            if isinstance(event, yaml.CollectionStartEvent):
                depth += 1
                if depth > MAX_DEPTH:
                    raise YamlRefused(f"YAML nested deeper than {MAX_DEPTH} levels", line)
            elif isinstance(event, yaml.CollectionEndEvent):
                depth -= 1
    finally:
        loader.dispose()
    if anchor is not None:  # (after the scan: an alias, the real danger, is named first when there is one)
        raise YamlRefused(f"YAML anchor &{anchor[0]} is not allowed{context} "
                          "(anchors only serve aliases, which can expand without bound)", anchor[1])


def load(text: str, *, limit: int = MAX_CHARS, context: str = "") -> Any:
    """The data of one YAML document (None when empty), after ``check``; YamlRefused or yaml.YAMLError."""
    check(text, limit=limit, context=context)
    return yaml.load(text, Loader=_Loader)  # noqa: S506 - the safe loader


def load_file(path: Any, *, limit: int = MAX_CHARS) -> Any:
    """``load`` of a UTF-8 file, reading at most ``limit`` characters of it (OSError, UnicodeDecodeError,
    YamlRefused or yaml.YAMLError)."""
    with open(path, encoding="utf-8") as f:
        text = f.read(limit + 1)
    return load(text, limit=limit)
