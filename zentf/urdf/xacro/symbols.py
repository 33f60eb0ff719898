"""xacro's scopes and the names every expression starts with.

A ``Table`` is one scope of properties (the document, a macro call, an included namespace), chained
to its parent; properties are evaluated lazily on first use, as xacro does. The global names are
xacro's own list: the math module, a few builtins (directly and under ``python.``), xacro's helpers
(``xacro.load_yaml``...). ``python.type`` and ``python.vars`` are not offered: in xacro they are the
way out of its sandbox (``python.vars(python.type(f))['__globals__']``); a model that uses them gets
one line saying so.
"""
from __future__ import annotations

import math
from typing import Any, Callable

from .errors import XacroError
from .evaluator import (DICT_METHODS, LIST_METHODS, Evaluator, ExprError, Function, Lambda, Method,
                        math_function, safe_type_name)

__all__ = ["Table", "NameSpace", "Globals", "YamlDict", "YamlList", "wrap", "eval_literal", "builtin_functions",
           "math_names"]


def eval_literal(value: Any) -> Any:
    """A property's text as xacro types it: 'quoted' -> the text inside, numbers, true/false; else the text."""
    if type(value) is not str:
        return value
    if len(value) >= 2 and value[0] == "'" and value[-1] == "'":
        return value[1:-1]
    if "_" in value:  # Python reads 1_000 as a number; xacro keeps such text as text
        return value
    for conv in (int, float):
        try:
            return conv(value)
        except (ValueError, OverflowError):
            pass
    if value in ("true", "True"):
        return True
    if value in ("false", "False"):
        return False
    return value


class Globals:
    """The root scope: xacro's built-in names."""

    __slots__ = ("names",)
    is_namespace = False

    def __init__(self, names: dict[str, Any]) -> None:
        self.names = names

    def lookup(self, name: str) -> Any:
        return self.names[name]

    def contains(self, name: str) -> bool:
        return name in self.names


class Table:
    """One scope of properties (or of macros), over its parent; lazily evaluated values."""

    __slots__ = ("vars", "parent", "root", "unevaluated", "resolving", "resolver", "warn")
    is_namespace = False

    def __init__(self, parent: "Table | Globals | None" = None, *,
                 resolver: Callable[[str, "Table"], Any] | None = None,
                 warn: Callable[[str], None] | None = None) -> None:
        if parent is None:
            parent = Globals({})
        self.parent = parent
        self.root: Globals = parent if type(parent) is Globals else parent.root  # type: ignore[union-attr]
        self.vars: dict[str, Any] = {}
        self.unevaluated: set[str] = set()
        self.resolving: list[str] = []
        self.resolver = resolver if resolver is not None else getattr(parent, "resolver", None)
        self.warn = warn if warn is not None else getattr(parent, "warn", None)

    # -- lookups (the evaluator's scope protocol)
    def lookup(self, name: str) -> Any:
        table: Any = self
        while type(table) is not Globals:
            if name in table.vars:
                return table._resolve(name)
            table = table.parent
        return table.lookup(name)

    def contains(self, name: str) -> bool:
        table: Any = self
        while type(table) is not Globals:
            if name in table.vars:
                return True
            table = table.parent
        return table.contains(name)

    def _resolve(self, name: str) -> Any:
        value = self.vars[name]
        if name in self.unevaluated:
            if name in self.resolving:
                raise XacroError("circular property definition: " + " -> ".join(self.resolving + [name]))
            if self.resolver is None:
                raise XacroError(f"property '{name}' cannot be evaluated here")
            self.resolving.append(name)
            try:
                value = eval_literal(self.resolver(value, self))
            finally:
                self.resolving.remove(name)
            self.vars[name] = value
            self.unevaluated.discard(name)
        return value

    # -- changes
    def set(self, name: str, value: Any, unevaluated: bool) -> None:
        if self.root.contains(name) and self.warn is not None:
            self.warn(f"redefining global symbol: {name}")
        value = eval_literal(value)
        self.vars[name] = value
        if unevaluated and type(value) is str:
            self.unevaluated.add(name)
        else:
            self.unevaluated.discard(name)

    def delete(self, name: str) -> None:
        table: Any = self
        while type(table) is not Globals:
            table.vars.pop(name, None)
            table.unevaluated.discard(name)
            table = table.parent
        if table.contains(name) and self.warn is not None:
            self.warn(f"cannot remove global symbol: {name}")

    def top(self) -> "Table":
        table = self
        while type(table.parent) is not Globals:
            table = table.parent  # type: ignore[assignment]
        return table

    # -- as a value in expressions (a namespace: ns.prop, ns['prop'], 'prop' in ns)
    def xacro_attr(self, name: str) -> Any:
        try:
            return self.lookup(name)
        except KeyError:
            raise ExprError(f"name '{name}' is not defined") from None

    def xacro_item(self, key: Any) -> Any:
        if type(key) is not str:
            raise ExprError("a namespace is indexed by names")
        return self.xacro_attr(key)

    def xacro_contains(self, key: Any) -> bool:
        return type(key) is str and self.contains(key)

    def __repr__(self) -> str:
        return "{" + ", ".join(f"{k!r}: ..." for k in self.vars) + "}"


class NameSpace(Table):
    """The scope of an ``<xacro:include ns=...>``, and the ``math``/``python``/``xacro`` name groups."""

    __slots__ = ()
    is_namespace = True


def _module(names: dict[str, Any]) -> NameSpace:
    ns = NameSpace()
    ns.vars.update(names)
    return ns


# ---------------------------------------------------------------------------- YAML values
class YamlDict(dict):
    """A dict from a YAML file: items also as attributes (``inertials.link1.mass``), nested values wrapped."""

    def __getitem__(self, key: Any) -> Any:
        return wrap(dict.__getitem__(self, key))

    def xacro_attr(self, name: str) -> Any:
        if name in DICT_METHODS:
            return Method(self, name)
        try:
            return wrap(dict.__getitem__(self, name))
        except KeyError:
            raise ExprError(f"the yaml dictionary has no key '{name}'") from None

    def xacro_item(self, key: Any) -> Any:
        try:
            return wrap(dict.__getitem__(self, key))
        except KeyError:
            raise ExprError(f"the yaml dictionary has no key {key!r}") from None
        except TypeError as e:
            raise ExprError(f"TypeError: {e}") from None

    def xacro_call(self, ev: Evaluator, name: str, args: list, kwargs: dict) -> Any:
        return _plain_call(ev, self, dict, name, args, kwargs)


class YamlList(list):
    """A list from a YAML file: its items wrapped (dicts with attribute access)."""

    def __getitem__(self, index: Any) -> Any:
        v = list.__getitem__(self, index)
        return YamlList(v) if type(index) is slice else wrap(v)

    def __iter__(self):
        for v in list.__iter__(self):
            yield wrap(v)

    def xacro_attr(self, name: str) -> Any:
        if name in LIST_METHODS:
            return Method(self, name)
        raise ExprError(f"attribute '{name}' of a list is not available in zentf's xacro")

    def xacro_call(self, ev: Evaluator, name: str, args: list, kwargs: dict) -> Any:
        return _plain_call(ev, self, list, name, args, kwargs)


def _plain_call(ev: Evaluator, obj: Any, base: type, name: str, args: list, kwargs: dict) -> Any:
    """An allowed method of a YAML value, run as on its plain base type (size checks included)."""
    for a in args:
        if type(a) in (Function, Lambda, Method) and not (base is list and name == "sort"):
            raise ExprError(f"{base.__name__}.{name} cannot take a function")
    if base is list and name in ("sort", "extend", "insert", "append"):
        ev.meter.length(len(obj) + 1, "a list")
        if name == "sort":
            key = kwargs.pop("key", None)
            list.sort(obj, key=None if key is None else ev.callable_of(key), reverse=bool(kwargs.get("reverse")))
            return None
        if name == "extend":
            items = ev.iterate(args[0])
            ev.meter.length(len(obj) + len(items), "a list")
            args = [items]
    result = getattr(base, name)(obj, *args, **kwargs)
    return ev.check_size(wrap(result), f"the result of {name}")


def wrap(value: Any) -> Any:
    t = type(value)
    if t is dict:
        return YamlDict(value)
    if t is list:
        return YamlList(value)
    return value


# ---------------------------------------------------------------------------- builtins
def _args(name: str, args: list, kwargs: dict, lo: int, hi: int, kw: tuple = ()) -> None:
    if not lo <= len(args) <= hi:
        raise ExprError(f"{name}() takes {lo}..{hi} arguments, {len(args)} given")
    bad = set(kwargs) - set(kw)
    if bad:
        raise ExprError(f"{name}() got an unexpected keyword argument '{sorted(bad)[0]}'")


def _scalar(name: str, v: Any) -> None:
    if type(v) not in (str, int, float, bool, complex):
        raise ExprError(f"{name}() of a {safe_type_name(v)} is not allowed")


def _make_list(ev: Evaluator, args: list, kwargs: dict) -> list:
    _args("list", args, kwargs, 0, 1)
    return list(ev.iterate(args[0], "a list")) if args else []


def _make_tuple(ev: Evaluator, args: list, kwargs: dict) -> tuple:
    _args("tuple", args, kwargs, 0, 1)
    return tuple(ev.iterate(args[0], "a tuple")) if args else ()


def _make_set(ev: Evaluator, args: list, kwargs: dict) -> set:
    _args("set", args, kwargs, 0, 1)
    return set(ev.iterate(args[0], "a set")) if args else set()


def _make_frozenset(ev: Evaluator, args: list, kwargs: dict) -> frozenset:
    _args("frozenset", args, kwargs, 0, 1)
    return frozenset(ev.iterate(args[0], "a set")) if args else frozenset()


def _make_dict(ev: Evaluator, args: list, kwargs: dict) -> dict:
    if len(args) > 1:
        raise ExprError("dict() takes at most one positional argument")
    out: dict = {}
    if args:
        src = args[0]
        if isinstance(src, dict):
            out.update(src)
        else:
            for pair in ev.iterate(src, "dict's items"):
                kv = ev.iterate(pair, "a key/value pair")
                if len(kv) != 2:
                    raise ExprError("dict() needs key/value pairs")
                out[kv[0]] = kv[1]
    out.update(kwargs)
    ev.meter.length(len(out), "a dict")
    return out


def _convert(name: str, conv: type) -> Callable[[Evaluator, list, dict], Any]:
    def impl(ev: Evaluator, args: list, kwargs: dict) -> Any:
        _args(name, args, kwargs, 0, 2 if conv in (int, complex) else 1)
        if conv is not str and conv is not bool:
            for a in args:
                _scalar(name, a)
        if conv is str:
            return ev.check_size(str(args[0]) if args else "", "a string")
        if conv is bool:
            return bool(args[0]) if args else False
        return conv(*args)
    return impl


def _len(ev: Evaluator, args: list, kwargs: dict) -> int:
    _args("len", args, kwargs, 1, 1)
    v = args[0]
    if isinstance(v, (str, list, tuple, dict, set, frozenset, range)) or type(v) in (type({}.keys()),
                                                                                  type({}.values()),
                                                                                  type({}.items())):
        return len(v)
    raise ExprError(f"len() of a {safe_type_name(v)} is not allowed")


def _map(ev: Evaluator, args: list, kwargs: dict) -> list:
    _args("map", args, kwargs, 2, 16)
    fn, seqs = args[0], [ev.iterate(a, "map's items") for a in args[1:]]
    out = []
    for items in zip(*seqs):
        ev.meter.tick()
        out.append(ev.call(fn, list(items)))
    return out


def _filter(ev: Evaluator, args: list, kwargs: dict) -> list:
    _args("filter", args, kwargs, 2, 2)
    fn, items = args[0], ev.iterate(args[1], "filter's items")
    out = []
    for x in items:
        ev.meter.tick()
        if (bool(x) if fn is None else ev.call(fn, [x])):
            out.append(x)
    return out


def _minmax(name: str, pick: Callable) -> Callable[[Evaluator, list, dict], Any]:
    def impl(ev: Evaluator, args: list, kwargs: dict) -> Any:
        _args(name, args, kwargs, 1, 1 << 16, ("key", "default"))
        items = ev.iterate(args[0], f"{name}'s items") if len(args) == 1 else list(args)
        if not items:
            if "default" in kwargs:
                return kwargs["default"]
            raise ExprError(f"{name}() of an empty sequence")
        key = kwargs.get("key")
        keyf = ev.callable_of(key) if key is not None else None
        ev.meter.tick(len(items))
        return pick(items, key=keyf)
    return impl


def _sorted(ev: Evaluator, args: list, kwargs: dict) -> list:
    _args("sorted", args, kwargs, 1, 1, ("key", "reverse"))
    items = list(ev.iterate(args[0], "sorted's items"))
    key = kwargs.get("key")
    ev.meter.tick(len(items))
    items.sort(key=None if key is None else ev.callable_of(key), reverse=bool(kwargs.get("reverse", False)))
    return items


def _range(ev: Evaluator, args: list, kwargs: dict) -> range:
    _args("range", args, kwargs, 1, 3)
    for a in args:
        if type(a) not in (int, bool) or a.bit_length() > 64:
            raise ExprError("range() needs integers (of at most 64 bits)")
    return range(*args)


def _sum(ev: Evaluator, args: list, kwargs: dict) -> Any:
    _args("sum", args, kwargs, 1, 2, ("start",))
    import ast as _ast
    total = args[1] if len(args) > 1 else kwargs.get("start", 0)
    for x in ev.iterate(args[0], "sum's items"):
        total = ev.binop(_ast.Add, total, x)
    return total


def _round(ev: Evaluator, args: list, kwargs: dict) -> Any:
    _args("round", args, kwargs, 1, 2, ("ndigits",))
    x = args[0]
    n = args[1] if len(args) > 1 else kwargs.get("ndigits")
    if type(x) not in (int, float, bool) or (n is not None and (type(n) not in (int, bool) or abs(n) > 1000)):
        raise ExprError("round() needs a number and at most 1000 digits")
    return round(x) if n is None else round(x, n)


def _simple(name: str, fn: Callable, lo: int, hi: int) -> Function:
    def impl(ev: Evaluator, args: list, kwargs: dict) -> Any:
        _args(name, args, kwargs, lo, hi)
        for a in args:
            if type(a) in (Function, Lambda, Method):
                raise ExprError(f"{name}() of a function is not allowed")
        return ev.check_size(fn(*args), f"{name}()")
    return Function(name, impl)


def _all_any(name: str, fn: Callable) -> Function:
    def impl(ev: Evaluator, args: list, kwargs: dict) -> bool:
        _args(name, args, kwargs, 1, 1)
        return fn(ev.iterate(args[0], f"{name}'s items"))
    return Function(name, impl)


def _enumerate(ev: Evaluator, args: list, kwargs: dict) -> list:
    _args("enumerate", args, kwargs, 1, 2, ("start",))
    start = args[1] if len(args) > 1 else kwargs.get("start", 0)
    if type(start) not in (int, bool):
        raise ExprError("enumerate() start must be an integer")
    return list(enumerate(ev.iterate(args[0], "enumerate's items"), start))


def _zip(ev: Evaluator, args: list, kwargs: dict) -> list:
    _args("zip", args, kwargs, 0, 64)
    return list(zip(*[ev.iterate(a, "zip's items") for a in args]))


def _reversed(ev: Evaluator, args: list, kwargs: dict) -> list:
    _args("reversed", args, kwargs, 1, 1)
    return ev.iterate(args[0], "reversed's items")[::-1]


def _isinstance(ev: Evaluator, args: list, kwargs: dict) -> bool:
    _args("isinstance", args, kwargs, 2, 2)
    return isinstance(args[0], _types_of(args[1]))


def _issubclass(ev: Evaluator, args: list, kwargs: dict) -> bool:
    _args("issubclass", args, kwargs, 2, 2)
    a = _types_of(args[0])
    if len(a) != 1:
        raise ExprError("issubclass() needs a type first")
    return issubclass(a[0], _types_of(args[1]))


def _types_of(spec: Any) -> tuple:
    specs = spec if type(spec) is tuple else (spec,)
    out = []
    for s in specs:
        if type(s) is not Function or s.pytype is None:
            raise ExprError("isinstance() needs types such as str, int, float, list, dict")
        out.append(s.pytype)
    return tuple(out)


def _refused(name: str) -> Function:
    def impl(ev: Evaluator, args: list, kwargs: dict) -> Any:
        raise ExprError(f"python.{name}() is not available in zentf's xacro (it reaches Python's internals)")
    return Function(name, impl)


def builtin_functions() -> dict[str, Function]:
    """The builtins xacro offers (under ``python.``; the first few also directly)."""
    fns: dict[str, Function] = {
        "list": Function("list", _make_list, list), "tuple": Function("tuple", _make_tuple, tuple),
        "set": Function("set", _make_set, set), "frozenset": Function("frozenset", _make_frozenset, frozenset),
        "dict": Function("dict", _make_dict, dict), "str": Function("str", _convert("str", str), str),
        "int": Function("int", _convert("int", int), int), "float": Function("float", _convert("float", float), float),
        "bool": Function("bool", _convert("bool", bool), bool),
        "complex": Function("complex", _convert("complex", complex), complex),
        "len": Function("len", _len), "map": Function("map", _map), "filter": Function("filter", _filter),
        "min": Function("min", _minmax("min", min)), "max": Function("max", _minmax("max", max)),
        "sorted": Function("sorted", _sorted), "range": Function("range", _range), "sum": Function("sum", _sum),
        "round": Function("round", _round), "abs": _simple("abs", abs, 1, 1),
        "divmod": _simple("divmod", divmod, 2, 2), "ord": _simple("ord", ord, 1, 1),
        "repr": _simple("repr", repr, 1, 1), "hash": _simple("hash", hash, 1, 1),
        "slice": _simple("slice", slice, 1, 3), "all": _all_any("all", all), "any": _all_any("any", any),
        "enumerate": Function("enumerate", _enumerate), "zip": Function("zip", _zip),
        "reversed": Function("reversed", _reversed), "isinstance": Function("isinstance", _isinstance),
        "issubclass": Function("issubclass", _issubclass), "type": _refused("type"), "vars": _refused("vars"),
    }
    return fns


def math_names() -> dict[str, Any]:
    """The math module's public names (functions wrapped, constants as they are)."""
    out: dict[str, Any] = {}
    for name in dir(math):
        if name.startswith("_"):
            continue
        v = getattr(math, name)
        out[name] = math_function(name) if callable(v) else v
    return out


def make_globals(xacro_functions: dict[str, Function]) -> Globals:
    """The root scope: xacro's direct names, and the ``python``, ``math`` and ``xacro`` namespaces."""
    fns = builtin_functions()
    maths = math_names()
    names: dict[str, Any] = {}
    for n in ("list", "dict", "map", "len", "str", "float", "int", "bool", "min", "max", "round", "sorted", "range"):
        names[n] = fns[n]
    names["True"], names["False"] = True, False
    python = dict(fns)
    python["True"], python["False"] = True, False
    names["python"] = _module(python)
    names.update(maths)
    names["math"] = _module(maths)
    names["xacro"] = _module(xacro_functions)
    for n in ("load_yaml", "abs_filename", "dotify"):  # xacro still offers these directly (deprecated)
        names[n] = xacro_functions[n]
    return Globals(names)
