"""YAML for ``xacro.load_yaml``: data only, bounded.

PyYAML's SafeLoader, with nesting bounded and anchors/aliases bounded: real robot descriptions use
them (franka's inertials.yaml: ``rightfinger: *finger``), and they are how a small YAML file becomes
gigabytes once walked, so the document as its aliases would unfold it is measured before it is built
(nodes and depth; recursive aliases are refused). xacro's unit tags (``!degrees 90``, ``!radians pi/2``, ``!meters``,
``!millimeters``, ``!foot``, ``!inches``) evaluated by the restricted expression evaluator.
"""
from __future__ import annotations

import math
from typing import Any, Callable

import yaml

from .errors import XacroError

__all__ = ["load_yaml_text", "UNIT_TAGS", "MAX_YAML_DEPTH"]

MAX_YAML_DEPTH = 64
#: Most nodes a YAML document may have once its aliases are unfolded.
MAX_YAML_NODES = 1_000_000
#: xacro's unit tags and their factor to SI (radians, metres).
UNIT_TAGS = {"!radians": 1.0, "!degrees": math.pi / 180.0, "!meters": 1.0, "!millimeters": 0.001,
             "!foot": 0.3048, "!inches": 0.0254}


class _Loader(yaml.SafeLoader):
    """SafeLoader without aliases, with a depth bound and the unit tags."""

    def __init__(self, stream: str, evaluate: Callable[[str], Any], tick: Callable[[], None]) -> None:
        super().__init__(stream)
        self._depth = 0
        self._evaluate = evaluate
        self._tick = tick

    def compose_node(self, parent: Any, index: Any) -> Any:
        event = self.peek_event()
        self._depth += 1
        self._tick()
        try:
            if self._depth > MAX_YAML_DEPTH:
                raise XacroError(f"YAML nested deeper than {MAX_YAML_DEPTH} (line {event.start_mark.line + 1})")
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1


def _unit(factor: float) -> Callable[[Any, Any], float]:
    def construct(loader: _Loader, node: Any) -> float:
        text = loader.construct_scalar(node)
        try:
            value = loader._evaluate(str(text))
            return float(value) * factor
        except XacroError as e:
            raise XacroError(f"{node.tag} {text!r}: {e}") from None
        except (TypeError, ValueError, OverflowError) as e:
            raise XacroError(f"{node.tag} {text!r}: {e}") from None
    return construct


for _tag, _factor in UNIT_TAGS.items():
    _Loader.add_constructor(_tag, _unit(_factor))


def _unfolded(root: Any, tick: Callable[[], None]) -> None:
    """Refuse a node graph whose unfolded tree (aliases copied out) is too large, too deep, or cyclic."""
    size: dict[int, tuple[int, int]] = {}   # id(node) -> (unfolded nodes, unfolded depth)
    on_path: set[int] = set()
    todo: list[tuple[Any, bool]] = [(root, False)]
    while todo:
        node, done = todo.pop()
        key = id(node)
        kids = [] if isinstance(node, yaml.ScalarNode) else \
            [c for pair in node.value for c in pair] if isinstance(node, yaml.MappingNode) else list(node.value)
        if done:
            on_path.discard(key)
            n = 1 + sum(size[id(c)][0] for c in kids)
            d = 1 + max((size[id(c)][1] for c in kids), default=0)
            if n > MAX_YAML_NODES or d > 4 * MAX_YAML_DEPTH:
                raise XacroError(f"YAML aliases unfold to more than {MAX_YAML_NODES} nodes or "
                                 f"{4 * MAX_YAML_DEPTH} levels")
            size[key] = (n, d)
            continue
        if key in size:
            continue
        if key in on_path:
            raise XacroError("a YAML alias refers to itself (recursive data is not allowed)")
        tick()
        on_path.add(key)
        todo.append((node, True))
        for c in kids:
            if id(c) in on_path:
                raise XacroError("a YAML alias refers to itself (recursive data is not allowed)")
            if id(c) not in size:
                todo.append((c, False))


def load_yaml_text(text: str, evaluate: Callable[[str], Any], tick: Callable[[], None]) -> Any:
    """The data of one YAML document; XacroError (one line) for anything refused or malformed."""
    loader = _Loader(text, evaluate, tick)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _unfolded(node, tick)
        return loader.construct_document(node)
    except XacroError:
        raise
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None else ""
        raise XacroError(f"bad YAML{where}: {getattr(e, 'problem', None) or e}") from None
    except RecursionError:
        raise XacroError("YAML nested too deeply") from None
    finally:
        loader.dispose()
