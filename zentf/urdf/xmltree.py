"""A minimal XML tree from the stdlib's expat that keeps each element's line number.

``xml.etree.ElementTree`` drops line numbers, and refusing a malformed URDF should point at the line.
"""
from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager
from xml.parsers import expat

from .errors import URDFError

__all__ = ["XElement", "parse_xml", "no_gc"]


class XElement:
    """One element: tag, attributes, child elements, the line it starts on."""

    __slots__ = ("tag", "attrib", "line", "children")

    def __init__(self, tag: str, attrib: dict[str, str], line: int) -> None:
        self.tag = tag
        self.attrib = attrib
        self.line = line
        self.children: list[XElement] = []

    def __repr__(self) -> str:
        return f"XElement({self.tag!r}, {self.attrib!r}, line={self.line}, {len(self.children)} children)"

    def findall(self, tag: str) -> list["XElement"]:
        return [c for c in self.children if c.tag == tag]

    def find(self, tag: str) -> "XElement | None":
        for c in self.children:
            if c.tag == tag:
                return c
        return None

    def get(self, name: str, default: str | None = None) -> str | None:
        return self.attrib.get(name, default)


@contextmanager
def no_gc() -> Iterator[None]:
    """The cyclic collector paused: a model's tree is acyclic (refcounting frees it), and the collector's
    passes over hundreds of thousands of new objects would take as long as building them."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def parse_xml(text: str | bytes, source: str | None = None) -> XElement:
    """Parse a document into XElements; a syntax error is a URDFError with its line."""
    parser = expat.ParserCreate()
    top = XElement("", {}, 0)  # holds the document element: every start appends to its parent, no branch
    stack = [top]

    # the handlers run once per element (a 100,000-link model has 700,000): locals only, expat's own
    # (fresh) attribute dict kept as it is
    def start(tag: str, attrs: dict[str, str], new=XElement, stack=stack, push=stack.append, p=parser) -> None:
        el = new(tag, attrs, p.CurrentLineNumber)
        stack[-1].children.append(el)
        push(el)

    def end(tag: str, pop=stack.pop) -> None:
        pop()

    def entity(*_args: object) -> None:
        raise URDFError("entity declarations are not allowed in a robot model", file=source,
                        line=parser.CurrentLineNumber)

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.EntityDeclHandler = entity  # a URDF needs none; they are how XML files multiply themselves
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
    try:
        with no_gc():
            parser.Parse(text, True)
    except expat.ExpatError as e:
        raise URDFError(f"not well-formed XML ({expat.ErrorString(e.code)}, column {e.offset})",
                        file=source, line=e.lineno) from None
    finally:
        # the handlers refer to the parser: a cycle that would keep the whole tree for the collector
        parser.StartElementHandler = parser.EndElementHandler = parser.EntityDeclHandler = None
    if not top.children:
        raise URDFError("empty document", file=source)
    return top.children[0]
