"""The small XML tree xacro works on: elements (tag, ordered attributes, children, file:line), text, comments.

Built with the stdlib's expat, keeping line numbers for error messages; entity declarations are refused
(a URDF never needs them, and they are how an XML file multiplies itself), and nesting is bounded.
Copying and writing walk the tree with an explicit stack, never by recursion.
"""
from __future__ import annotations

from xml.parsers import expat

from .errors import XacroError

__all__ = ["Element", "Text", "Comment", "parse", "serialize", "clone", "MAX_DEPTH"]

#: Deepest element nesting a model file may have (real robots: about 10).
MAX_DEPTH = 256


class Text:
    __slots__ = ("data",)

    def __init__(self, data: str) -> None:
        self.data = data


class Comment:
    __slots__ = ("data",)

    def __init__(self, data: str) -> None:
        self.data = data


class Element:
    """An element; ``file`` and ``line`` say where it was written (for error messages)."""

    __slots__ = ("tag", "attrs", "children", "file", "line")

    def __init__(self, tag: str, attrs: dict[str, str] | None = None, children: list | None = None,
                 file: str | None = None, line: int | None = None) -> None:
        self.tag = tag
        self.attrs = attrs if attrs is not None else {}
        self.children = children if children is not None else []
        self.file = file
        self.line = line

    def elements(self) -> list["Element"]:
        return [c for c in self.children if type(c) is Element]


Node = Element | Text | Comment


def parse(data: bytes, file: str | None, meter=None) -> Element:
    """The document element of ``data``; XacroError (one line, file:line) when it is not well-formed."""
    parser = expat.ParserCreate()
    parser.SetParamEntityParsing(expat.XML_PARAM_ENTITY_PARSING_NEVER)
    stack: list[Element] = []
    root: list[Element] = []

    def start(tag: str, attrs: dict[str, str]) -> None:
        if len(stack) >= MAX_DEPTH:
            raise XacroError(f"elements nested deeper than {MAX_DEPTH}", file, parser.CurrentLineNumber)
        if meter is not None:
            meter.element()
        el = Element(tag, attrs, None, file, parser.CurrentLineNumber)
        if stack:
            stack[-1].children.append(el)
        elif root:
            raise XacroError("more than one document element", file, parser.CurrentLineNumber)
        else:
            root.append(el)
        stack.append(el)

    def end(tag: str) -> None:
        stack.pop()

    def chars(data: str) -> None:
        if stack:
            kids = stack[-1].children
            if kids and type(kids[-1]) is Text:
                kids[-1].data += data
            else:
                kids.append(Text(data))

    def comment(data: str) -> None:
        if stack:
            stack[-1].children.append(Comment(data))

    def entity(*_args) -> None:
        raise XacroError("entity declarations are not allowed in a robot model", file, parser.CurrentLineNumber)

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = chars
    parser.CommentHandler = comment
    parser.EntityDeclHandler = entity
    parser.buffer_text = True
    try:
        parser.Parse(data, True)
    except expat.ExpatError as e:
        raise XacroError(f"not well-formed XML ({expat.ErrorString(e.code)}, column {e.offset})", file,
                         e.lineno) from None
    if not root:
        raise XacroError("empty document", file, None)
    return root[0]


def clone(node: Node, meter=None) -> Node:
    """A deep copy (iterative)."""
    if type(node) is Text:
        return Text(node.data)
    if type(node) is Comment:
        return Comment(node.data)
    top = Element(node.tag, dict(node.attrs), [], node.file, node.line)
    todo = [(node, top)]
    n = 1
    while todo:
        src, dst = todo.pop()
        out = dst.children
        for c in src.children:
            t = type(c)
            if t is Element:
                d = Element(c.tag, dict(c.attrs), [], c.file, c.line)
                n += 1
                out.append(d)
                todo.append((c, d))
            elif t is Text:
                out.append(Text(c.data))
            else:
                out.append(Comment(c.data))
    if meter is not None:
        meter.element(n)
    return top


def _attr(value: str) -> str:
    return (value.replace("&", "&amp;").replace("<", "&lt;").replace('"', "&quot;").replace(">", "&gt;")
            .replace("\n", "&#10;").replace("\r", "&#13;").replace("\t", "&#9;"))


def _text(value: str) -> str:
    return value.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace("\r", "&#13;")


def serialize(root: Element, limit: int | None = None) -> str:
    """The tree as XML text (an XML declaration first); XacroError when it grows past ``limit`` characters."""
    out: list[str] = ['<?xml version="1.0" ?>\n']
    size = 0
    todo: list = [root]
    while todo:
        node = todo.pop()
        t = type(node)
        if t is str:  # a closing tag
            piece = node
        elif t is Text:
            data = node.data
            if data.count("\n") > 1 and not data.strip():  # blank lines where xacro elements were: one break
                data = "\n" + data.rsplit("\n", 1)[1]
            piece = _text(data)
        elif t is Comment:
            piece = "<!--" + node.data + "-->"
        else:
            attrs = "".join(f' {k}="{_attr(v)}"' for k, v in node.attrs.items())
            if node.children:
                piece = f"<{node.tag}{attrs}>"
                todo.append(f"</{node.tag}>")
                todo.extend(reversed(node.children))
            else:
                piece = f"<{node.tag}{attrs}/>"
        out.append(piece)
        size += len(piece)
        if limit is not None and size > limit:
            from .errors import BudgetExceeded
            raise BudgetExceeded(f"xacro expansion stopped: the URDF grew past {limit} characters, over its "
                                 f"memory budget (raise it with --xacro-budget)")
    out.append("\n")
    return "".join(out)
