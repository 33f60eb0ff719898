"""A minimal XML tree from the stdlib's expat that keeps each element's line number.

``xml.etree.ElementTree`` drops line numbers, and refusing a malformed URDF should point at the line.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from xml.parsers import expat

from .errors import URDFError

__all__ = ["XElement", "parse_xml"]


@dataclass(slots=True)
class XElement:
    """One element: tag, attributes, child elements, the line it starts on."""

    tag: str
    attrib: dict[str, str]
    line: int
    children: list["XElement"] = field(default_factory=list)

    def findall(self, tag: str) -> list["XElement"]:
        return [c for c in self.children if c.tag == tag]

    def find(self, tag: str) -> "XElement | None":
        for c in self.children:
            if c.tag == tag:
                return c
        return None

    def get(self, name: str, default: str | None = None) -> str | None:
        return self.attrib.get(name, default)


def parse_xml(text: str | bytes, source: str | None = None) -> XElement:
    """Parse a document into XElements; a syntax error is a URDFError with its line."""
    parser = expat.ParserCreate()
    stack: list[XElement] = []
    root: list[XElement] = []

    def start(tag: str, attrs: dict[str, str]) -> None:
        el = XElement(tag, dict(attrs), parser.CurrentLineNumber)
        if stack:
            stack[-1].children.append(el)
        else:
            root.append(el)
        stack.append(el)

    def end(tag: str) -> None:
        stack.pop()

    def entity(*_args: object) -> None:
        raise URDFError("entity declarations are not allowed in a robot model", file=source,
                        line=parser.CurrentLineNumber)

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.EntityDeclHandler = entity  # a URDF needs none; they are how XML files multiply themselves
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
    try:
        parser.Parse(text, True)
    except expat.ExpatError as e:
        raise URDFError(f"not well-formed XML ({expat.ErrorString(e.code)}, column {e.offset})",
                        file=source, line=e.lineno) from None
    if not root:
        raise URDFError("empty document", file=source)
    return root[0]
