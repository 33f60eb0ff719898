"""YAML loaded into a tree that remembers the line of every value, for file:line errors."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Union

import yaml

from ..core import safe_yaml
from .errors import LaunchError

__all__ = ["Y", "load_yaml_file", "load_yaml_text"]

Loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


@dataclass(eq=False)
class Y:
    """One YAML value: a scalar, a list of Y, or a dict of str -> Y, with its 1-based line."""

    value: Union[None, bool, int, float, str, list["Y"], dict[str, "Y"]]
    line: int
    file: str
    plain: bool = True  # an unquoted scalar: substituted text is re-read as a YAML scalar
    key_lines: dict[str, int] = field(default_factory=dict)
    raw: str | None = None  # a scalar's text as written (`0.40`, `true`), for command words

    def error(self, message: str, key: str | None = None) -> LaunchError:
        line = self.key_lines.get(key, self.line) if key is not None else self.line
        return LaunchError(message, self.file, line)

    @property
    def is_map(self) -> bool:
        return isinstance(self.value, dict)

    @property
    def is_list(self) -> bool:
        return isinstance(self.value, list)

    @property
    def is_scalar(self) -> bool:
        return not isinstance(self.value, (dict, list))

    def plain_value(self) -> Any:
        """The value as plain Python (dicts, lists, scalars), without line information."""
        if isinstance(self.value, dict):
            return {k: v.plain_value() for k, v in self.value.items()}
        if isinstance(self.value, list):
            return [v.plain_value() for v in self.value]
        return self.value


def load_yaml_file(path: str, display: str | None = None) -> Y | None:
    """Read and parse a YAML file; None for an empty document."""
    shown = display or path
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except FileNotFoundError:
        raise LaunchError("file not found", shown) from None
    except (OSError, UnicodeDecodeError) as e:
        raise LaunchError(f"cannot read: {e}", shown) from None
    return load_yaml_text(text, shown)


def load_yaml_text(text: str, file: str) -> Y | None:
    try:
        _refuse_aliases(text, file)
        loader = Loader(text)
        try:
            node = loader.get_single_node()
            if node is None:
                return None
            return _convert(node, loader, file)
        finally:
            loader.dispose()
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        what = " ".join(p for p in (e.context, e.problem) if p) or "invalid YAML"
        raise LaunchError(f"YAML error: {what}", file, mark.line + 1 if mark else None) from None
    except yaml.reader.ReaderError as e:
        line = text.count("\n", 0, e.position) + 1 if isinstance(e.position, int) else None
        raise LaunchError(f"YAML error: character {e.character!r} is not allowed ({e.reason})", file, line) from None
    except yaml.YAMLError as e:
        raise LaunchError(f"YAML error: {str(e).strip().splitlines()[0]}", file) from None


def _refuse_aliases(text: str, file: str) -> None:
    """Refuse `*alias`, `&anchor` and tags before composing (``zentf.core.safe_yaml``): a few lines of
    nested aliases expand to billions of values (the "billion laughs"), and a launch file gains nothing
    from them that repetition cannot give."""
    try:
        safe_yaml.check(text, context=" in a launch file")
    except safe_yaml.YamlRefused as e:
        raise LaunchError(e.problem, file, e.line) from None


def _convert(node: yaml.Node, loader: Any, file: str) -> Y:
    line = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        out: dict[str, Y] = {}
        key_lines: dict[str, int] = {}
        loader.flatten_mapping(node)
        for knode, vnode in node.value:
            kline = knode.start_mark.line + 1
            if not isinstance(knode, yaml.ScalarNode):
                raise LaunchError("a key must be a plain string", file, kline)
            key = loader.construct_object(knode)
            if key is None or isinstance(key, (list, dict)):
                raise LaunchError(f"bad key {knode.value!r}", file, kline)
            key = str(key) if not isinstance(key, bool) else knode.value
            if key in out:
                raise LaunchError(f"duplicate key {key!r} (first on line {key_lines[key]})", file, kline)
            out[key] = _convert(vnode, loader, file)
            key_lines[key] = kline
        return Y(out, line, file, key_lines=key_lines)
    if isinstance(node, yaml.SequenceNode):
        return Y([_convert(n, loader, file) for n in node.value], line, file)
    try:
        value = loader.construct_object(node, deep=True)
    except yaml.constructor.ConstructorError as e:
        raise LaunchError(f"YAML error: {e.problem}", file, line) from None
    if not isinstance(value, (type(None), bool, int, float, str)):
        value = node.value  # timestamps, binary: keep the text as written
    return Y(value, line, file, plain=not node.style, raw=node.value)  # style: CLoader "", pure None
