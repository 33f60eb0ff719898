"""xacro's ``${...}`` expressions, evaluated without Python's ``eval``: a small interpreter over Python's
expression syntax (``ast``) that knows only what robot models use.

Allowed: numbers, strings, lists, tuples, dicts, sets; arithmetic, comparisons, ``and``/``or``/``not``,
``x if c else y``; property names; subscripts and slices; calls of the functions the symbol table
offers (math, a few builtins, xacro's) and of a fixed list of str/list/dict methods; comprehensions,
lambdas and f-strings. Refused: names and attributes starting with ``_``, any attribute that is not
on the list, walrus, ``await``/``yield``, and every object that did not come from this module or
the symbol table. So there is no path to Python's internals, whatever the text says.

Every step is metered (``Meter``): sizes are checked before a string, list or integer is made
(``'x' * 10**10``, ``10**10**10``, ``'{:999999999}'.format(1)`` are refused at once), iterations
count, and the CPU budget is read every few thousand steps. Nesting (of the expression, of lambda
calls) is bounded, so a hostile expression cannot exhaust Python's stack either.
"""
from __future__ import annotations

import ast
import math
import operator
import re
import string
from typing import Any, Callable

from .budget import Meter
from .errors import BudgetExceeded, XacroError

__all__ = ["Evaluator", "Function", "Lambda", "Method", "ExprError", "MAX_EXPRESSION", "safe_type_name"]

#: Longest expression text parsed (real ones: well under 1 kB).
MAX_EXPRESSION = 65536
#: Deepest nesting of expression nodes, lambda calls and lazily evaluated properties together.
MAX_DEPTH = 400
#: Largest integer made by arithmetic, in bits (about 20,000 decimal digits).
MAX_INT_BITS = 65536
#: Largest width or precision in a format specification.
MAX_FORMAT_WIDTH = 10000


class ExprError(XacroError):
    """An expression that cannot be evaluated (one line)."""


def safe_type_name(value: Any) -> str:
    return type(value).__name__


class Function:
    """A function an expression may call: ``impl(evaluator, args, kwargs)``; ``pytype`` when it stands
    for a type (``str``, ``int``... for ``isinstance``)."""

    __slots__ = ("name", "impl", "pytype")

    def __init__(self, name: str, impl: Callable[["Evaluator", list, dict], Any], pytype: type | None = None) -> None:
        self.name = name
        self.impl = impl
        self.pytype = pytype

    def __repr__(self) -> str:
        return f"<function {self.name}>"


class Lambda:
    """A ``lambda`` written in an expression, closed over the names it was made with."""

    __slots__ = ("params", "defaults", "body", "env")

    def __init__(self, params: list[str], defaults: list, body: ast.AST, env: "_Env") -> None:
        self.params, self.defaults, self.body, self.env = params, defaults, body, env

    def __repr__(self) -> str:
        return "<lambda>"


class Method:
    """A bound method from the allowed list (``'a b'.split``)."""

    __slots__ = ("obj", "name")

    def __init__(self, obj: Any, name: str) -> None:
        self.obj, self.name = obj, name

    def __repr__(self) -> str:
        return f"<method {type(self.obj).__name__}.{self.name}>"


# Methods an expression may call, by the exact type of the object (subclasses made here declare theirs).
_STR_METHODS = frozenset({
    "capitalize", "casefold", "center", "count", "endswith", "expandtabs", "find", "format", "index", "isalnum",
    "isalpha", "isascii", "isdecimal", "isdigit", "isidentifier", "islower", "isnumeric", "isprintable", "isspace",
    "istitle", "isupper", "join", "ljust", "lower", "lstrip", "partition", "removeprefix", "removesuffix", "replace",
    "rfind", "rindex", "rjust", "rpartition", "rsplit", "rstrip", "split", "splitlines", "startswith", "strip",
    "swapcase", "title", "upper", "zfill"})
LIST_METHODS = frozenset({"append", "clear", "copy", "count", "extend", "index", "insert", "pop", "remove", "reverse",
                          "sort"})
_TUPLE_METHODS = frozenset({"count", "index"})
DICT_METHODS = frozenset({"clear", "copy", "get", "items", "keys", "pop", "popitem", "setdefault", "update",
                          "values"})
_SET_METHODS = frozenset({"add", "copy", "difference", "discard", "intersection", "isdisjoint", "issubset",
                          "issuperset", "pop", "remove", "symmetric_difference", "union", "update"})
_NUMBER_ATTRS = {int: frozenset({"real", "imag", "numerator", "denominator"}),
                 bool: frozenset({"real", "imag", "numerator", "denominator"}),
                 float: frozenset({"real", "imag"}), complex: frozenset({"real", "imag"})}
_NUMBER_METHODS = {int: frozenset({"bit_length", "conjugate"}), bool: frozenset({"bit_length", "conjugate"}),
                   float: frozenset({"is_integer", "conjugate", "hex"}), complex: frozenset({"conjugate"})}
_METHODS = {str: _STR_METHODS, list: LIST_METHODS, tuple: _TUPLE_METHODS, dict: DICT_METHODS,
            set: _SET_METHODS, frozenset: _SET_METHODS - {"add", "discard", "pop", "remove", "update"}}

_ITERABLE = (str, list, tuple, dict, set, frozenset, range, type({}.keys()), type({}.values()), type({}.items()))
_SIZED_RESULT = (str, list, tuple, dict, set, frozenset)
_CONSTANTS = (str, int, float, complex, bool, type(None))
_FORMAT_NUMBER = re.compile(r"\d+")
_PERCENT_SPEC = re.compile(r"%(?:\([^)]*\))?[#0\- +]*(\*|\d+)?(?:\.(\*|\d+))?[hlL]?(.)", re.S)


class _Env:
    """Local names (lambda parameters, comprehension variables) over the property scope."""

    __slots__ = ("vars", "parent", "scope")

    def __init__(self, vars: dict, parent: "_Env | None", scope: Any) -> None:
        self.vars, self.parent, self.scope = vars, parent, scope

    def lookup(self, name: str) -> Any:
        env: _Env | None = self
        while env is not None:
            if name in env.vars:
                return env.vars[name]
            env = env.parent
        return self.scope.lookup(name)


def _format_spec_ok(spec: str) -> None:
    if "{" in spec or "}" in spec:
        raise ExprError("nested replacement fields in a format specification are not allowed")
    for m in _FORMAT_NUMBER.findall(spec):
        if len(m) > 5 or int(m) > MAX_FORMAT_WIDTH:
            raise ExprError(f"format width or precision {m} is over {MAX_FORMAT_WIDTH}")


def _check_format_string(fmt: str) -> None:
    """str.format's fields may name positions or keywords only: ``{0.attr}``/``{0[key]}`` reach into objects."""
    try:
        parsed = list(string.Formatter().parse(fmt))
    except ValueError as e:
        raise ExprError(f"bad format string: {e}") from None
    for _text, field, spec, conversion in parsed:
        if field is None:
            continue
        if not (field == "" or field.isdigit() or field.isidentifier()):
            raise ExprError(f"format field '{{{field}}}' is not allowed (only positions and names)")
        if conversion not in (None, "r", "s", "a"):
            raise ExprError(f"bad conversion !{conversion}")
        _format_spec_ok(spec or "")


def _check_percent(fmt: str) -> None:
    for m in _PERCENT_SPEC.finditer(fmt):
        for part in (m.group(1), m.group(2)):
            if part == "*":
                raise ExprError("'*' widths in %-formatting are not allowed")
            if part is not None and (len(part) > 5 or int(part) > MAX_FORMAT_WIDTH):
                raise ExprError(f"%-format width or precision {part} is over {MAX_FORMAT_WIDTH}")


class Evaluator:
    """Evaluates expression text against a scope (anything with ``lookup(name)``, KeyError when unknown)."""

    def __init__(self, meter: Meter) -> None:
        self.meter = meter
        self.depth = 0
        self._cache: dict[str, ast.AST] = {}
        self._nodes: dict[type, Callable[[Any, _Env], Any]] = {
            ast.Expression: lambda n, e: self._eval(n.body, e),
            ast.Constant: self._constant, ast.Name: self._name, ast.Attribute: self._attribute,
            ast.Subscript: self._subscript, ast.BinOp: self._binop, ast.UnaryOp: self._unaryop,
            ast.BoolOp: self._boolop, ast.Compare: self._compare, ast.IfExp: self._ifexp, ast.Call: self._call,
            ast.List: lambda n, e: self._sized(self._items(n.elts, e), "a list"),
            ast.Tuple: lambda n, e: tuple(self._sized(self._items(n.elts, e), "a tuple")),
            ast.Set: lambda n, e: set(self._sized(self._items(n.elts, e), "a set")),
            ast.Dict: self._dict, ast.ListComp: self._listcomp, ast.SetComp: self._setcomp,
            ast.GeneratorExp: self._listcomp, ast.DictComp: self._dictcomp, ast.Lambda: self._lambda,
            ast.JoinedStr: self._joinedstr, ast.FormattedValue: self._formatted, ast.Slice: self._slice,
        }

    # ------------------------------------------------------------------ entry points
    def evaluate(self, text: str, scope: Any) -> Any:
        """The value of expression ``text``; ExprError (one line) for anything refused or failing."""
        tree = self._parse(text)
        try:
            return self._eval(tree, _Env({}, None, scope))
        except (XacroError, BudgetExceeded):
            raise
        except RecursionError:
            raise ExprError("expression nested too deeply") from None
        except MemoryError:
            raise BudgetExceeded("xacro expression stopped: out of its memory budget (raise it with "
                                 "--xacro-budget)") from None
        except KeyError as e:
            raise ExprError(f"KeyError: {e}") from None
        except Exception as e:  # noqa: BLE001 - TypeError, ValueError, ZeroDivisionError... from the values
            raise ExprError(f"{type(e).__name__}: {e}") from None

    def call(self, fn: Any, args: list, kwargs: dict | None = None) -> Any:
        """Call something an expression may call."""
        kwargs = kwargs or {}
        t = type(fn)
        if t is Function:
            return fn.impl(self, args, kwargs)
        if t is Lambda:
            return self._call_lambda(fn, args, kwargs)
        if t is Method:
            return self._call_method(fn.obj, fn.name, args, kwargs)
        raise ExprError(f"a {safe_type_name(fn)} is not callable")

    def iterate(self, obj: Any, what: str = "a value") -> list:
        """The items of an iterable as a list, metered (only the kinds of value expressions make)."""
        if isinstance(obj, _ITERABLE):
            n = len(obj)  # range of more than sys.maxsize items: OverflowError, reported as such
            self.meter.length(n, what)
            return list(obj)
        xi = getattr(type(obj), "xacro_iter", None)
        if xi is not None:
            return xi(obj)
        raise ExprError(f"a {safe_type_name(obj)} is not iterable")

    def check_size(self, value: Any, what: str = "a value") -> Any:
        if isinstance(value, _SIZED_RESULT):
            self.meter.length(len(value), what)
        elif type(value) is int and value.bit_length() > MAX_INT_BITS:
            raise BudgetExceeded(f"xacro expression stopped: an integer of {value.bit_length()} bits is over "
                                 f"{MAX_INT_BITS}")
        return value

    # ------------------------------------------------------------------ parsing
    def _parse(self, text: str) -> ast.AST:
        tree = self._cache.get(text)
        if tree is not None:
            return tree
        src = text.strip()
        if len(src) > MAX_EXPRESSION:
            raise ExprError(f"expression of {len(src)} characters is longer than {MAX_EXPRESSION}")
        try:
            tree = ast.parse(src, mode="eval")
        except SyntaxError as e:
            raise ExprError(f"invalid expression: {e.msg}") from None
        except (ValueError, RecursionError, MemoryError, OverflowError) as e:
            raise ExprError(f"invalid expression: {type(e).__name__}") from None
        if len(self._cache) < 4096 and len(src) <= 1024:  # the cache stays small (a few MB)
            self._cache[text] = tree
        return tree

    # ------------------------------------------------------------------ nodes
    def _eval(self, node: ast.AST, env: _Env) -> Any:
        self.depth += 1
        try:
            if self.depth > MAX_DEPTH:
                raise ExprError(f"expression (or its lambda calls) nested deeper than {MAX_DEPTH}")
            self.meter.tick()
            handler = self._nodes.get(type(node))
            if handler is None:
                raise ExprError(f"{type(node).__name__} is not allowed in a xacro expression")
            return handler(node, env)
        finally:
            self.depth -= 1

    def _constant(self, node: ast.Constant, env: _Env) -> Any:
        if not isinstance(node.value, _CONSTANTS):
            raise ExprError(f"a {safe_type_name(node.value)} literal is not allowed")
        return node.value

    def _name(self, node: ast.Name, env: _Env) -> Any:
        name = node.id
        if name.startswith("__"):
            raise ExprError(f"name '{name}' is not allowed (names starting with '__' are refused)")
        try:
            return env.lookup(name)
        except KeyError:
            raise ExprError(f"name '{name}' is not defined") from None

    def _attribute(self, node: ast.Attribute, env: _Env) -> Any:
        return self.get_attr(self._eval(node.value, env), node.attr)

    def get_attr(self, obj: Any, name: str) -> Any:
        if name.startswith("_"):
            raise ExprError(f"attribute '{name}' is not allowed (names starting with '_' are refused)")
        own = getattr(type(obj), "xacro_attr", None)
        if own is not None:
            return own(obj, name)
        t = type(obj)
        if name in _METHODS.get(t, ()) or name in _NUMBER_METHODS.get(t, ()):
            return Method(obj, name)
        if name in _NUMBER_ATTRS.get(t, ()):
            return getattr(obj, name)
        raise ExprError(f"attribute '{name}' of a {safe_type_name(obj)} is not available in zentf's xacro")

    def _subscript(self, node: ast.Subscript, env: _Env) -> Any:
        obj = self._eval(node.value, env)
        key = self._eval(node.slice, env)
        own = getattr(type(obj), "xacro_item", None)
        if own is not None:
            return own(obj, key)
        if isinstance(obj, (str, list, tuple, dict, range)):
            if type(key) is slice:
                return self.check_size(obj[key], "a slice")
            return obj[key]
        raise ExprError(f"a {safe_type_name(obj)} cannot be indexed")

    def _slice(self, node: ast.Slice, env: _Env) -> slice:
        parts = [None if p is None else self._eval(p, env) for p in (node.lower, node.upper, node.step)]
        for p in parts:
            if p is not None and type(p) not in (int, bool):
                raise ExprError(f"slice indices must be integers, not {safe_type_name(p)}")
        return slice(*parts)

    def _items(self, elts: list, env: _Env) -> list:
        out: list = []
        for el in elts:
            if type(el) is ast.Starred:
                out.extend(self.iterate(self._eval(el.value, env), "an unpacked value"))
            else:
                out.append(self._eval(el, env))
        return out

    def _sized(self, items: list, what: str) -> list:
        self.meter.length(len(items), what)
        return items

    def _dict(self, node: ast.Dict, env: _Env) -> dict:
        out: dict = {}
        for k, v in zip(node.keys, node.values):
            if k is None:
                m = self._eval(v, env)
                if not isinstance(m, dict):
                    raise ExprError(f"** needs a dict, not a {safe_type_name(m)}")
                out.update(m)
            else:
                out[self._eval(k, env)] = self._eval(v, env)
            self.meter.length(len(out), "a dict")
        return out

    # ------------------------------------------------------------------ operators
    def _binop(self, node: ast.BinOp, env: _Env) -> Any:
        return self.binop(type(node.op), self._eval(node.left, env), self._eval(node.right, env))

    def binop(self, op: type, a: Any, b: Any) -> Any:
        fn = _BINOPS.get(op)
        if fn is None:
            raise ExprError(f"operator {op.__name__} is not allowed")
        _check_binop(self, op, a, b)
        return self.check_size(fn(a, b), "a result")

    def _unaryop(self, node: ast.UnaryOp, env: _Env) -> Any:
        v = self._eval(node.operand, env)
        op = type(node.op)
        if op is ast.Not:
            return not v
        if not isinstance(v, (int, float, complex)):
            raise ExprError(f"bad operand type for unary {op.__name__}: {safe_type_name(v)}")
        if op is ast.USub:
            return -v
        if op is ast.UAdd:
            return +v
        return ~v

    def _boolop(self, node: ast.BoolOp, env: _Env) -> Any:
        value: Any = None
        for v in node.values:
            value = self._eval(v, env)
            if (type(node.op) is ast.And) != bool(value):
                return value
        return value

    def _compare(self, node: ast.Compare, env: _Env) -> bool:
        left = self._eval(node.left, env)
        for op, right_node in zip(node.ops, node.comparators):
            right = self._eval(right_node, env)
            t = type(op)
            if t in (ast.In, ast.NotIn):
                if not (isinstance(right, _ITERABLE) or hasattr(type(right), "xacro_contains")):
                    raise ExprError(f"'in' needs a container, not a {safe_type_name(right)}")
                own = getattr(type(right), "xacro_contains", None)
                hit = own(right, left) if own is not None else left in right
                ok = hit if t is ast.In else not hit
            else:
                ok = _COMPARE[t](left, right)
            if not ok:
                return False
            left = right
        return True

    def _ifexp(self, node: ast.IfExp, env: _Env) -> Any:
        return self._eval(node.body if self._eval(node.test, env) else node.orelse, env)

    # ------------------------------------------------------------------ calls
    def _call(self, node: ast.Call, env: _Env) -> Any:
        fn = self._eval(node.func, env)
        args = self._items(node.args, env)
        kwargs: dict = {}
        for kw in node.keywords:
            if kw.arg is None:
                m = self._eval(kw.value, env)
                if not isinstance(m, dict) or not all(type(k) is str for k in m):
                    raise ExprError("** in a call needs a dict with string keys")
                kwargs.update(m)
            else:
                kwargs[kw.arg] = self._eval(kw.value, env)
        for k in kwargs:
            if k.startswith("_"):
                raise ExprError(f"keyword '{k}' is not allowed")
        return self.call(fn, args, kwargs)

    def _lambda(self, node: ast.Lambda, env: _Env) -> Lambda:
        a = node.args
        if a.vararg or a.kwarg or a.kwonlyargs:
            raise ExprError("lambdas may have plain parameters only")
        params = [p.arg for p in (*a.posonlyargs, *a.args)]
        for p in params:
            if p.startswith("__"):
                raise ExprError(f"parameter name '{p}' is not allowed")
        return Lambda(params, [self._eval(d, env) for d in a.defaults], node.body, env)

    def _call_lambda(self, fn: Lambda, args: list, kwargs: dict) -> Any:
        params = fn.params
        if len(args) > len(params):
            raise ExprError(f"lambda takes {len(params)} arguments, {len(args)} given")
        bound = dict(zip(params, args))
        for k, v in kwargs.items():
            if k not in params or k in bound:
                raise ExprError(f"lambda got an unexpected or repeated argument '{k}'")
            bound[k] = v
        first_default = len(params) - len(fn.defaults)
        for i, p in enumerate(params):
            if p not in bound:
                if i < first_default:
                    raise ExprError(f"lambda missing argument '{p}'")
                bound[p] = fn.defaults[i - first_default]
        self.depth += 1
        try:
            if self.depth > MAX_DEPTH:
                raise ExprError(f"expression (or its lambda calls) nested deeper than {MAX_DEPTH}")
            return self._eval(fn.body, _Env(bound, fn.env, fn.env.scope))
        finally:
            self.depth -= 1

    def callable_of(self, fn: Any) -> Callable:
        """A Python callable running ``fn`` through this evaluator (for sort keys)."""
        if type(fn) not in (Function, Lambda, Method):
            raise ExprError(f"a {safe_type_name(fn)} is not callable")
        return lambda *a: self.call(fn, list(a))

    def _call_method(self, obj: Any, name: str, args: list, kwargs: dict) -> Any:
        own = getattr(type(obj), "xacro_call", None)
        if own is not None:
            return own(obj, self, name, args, kwargs)
        t = type(obj)
        m = self.meter
        if t is str:
            if name == "join":
                if len(args) != 1 or kwargs:
                    raise ExprError("join takes one argument")
                items = self.iterate(args[0], "the items of join")
                if not all(type(x) is str for x in items):
                    raise ExprError("join needs strings")
                m.length(sum(map(len, items)) + len(obj) * max(0, len(items) - 1), "a joined string")
                return obj.join(items)
            if name == "replace":
                if len(args) < 2 or type(args[0]) is not str or type(args[1]) is not str:
                    raise ExprError("replace needs two strings")
                old, new = args[0], args[1]
                n = obj.count(old) if old else len(obj) + 1
                if len(args) > 2 and type(args[2]) is int and args[2] >= 0:
                    n = min(n, args[2])
                m.length(len(obj) + n * max(0, len(new) - len(old)), "a replaced string")
            elif name in ("center", "ljust", "rjust", "zfill"):
                if args and type(args[0]) is int:
                    m.length(args[0], "a padded string")
            elif name == "expandtabs":
                size = args[0] if args else kwargs.get("tabsize", 8)
                if type(size) is not int:
                    raise ExprError("expandtabs needs an integer")
                m.length(len(obj) * max(1, size), "an expanded string")
            elif name == "format":
                _check_format_string(obj)
        elif t is list:
            if name == "sort":
                key = kwargs.pop("key", None)
                if args or set(kwargs) - {"reverse"}:
                    raise ExprError("sort takes key= and reverse= only")
                m.tick(len(obj))
                obj.sort(key=None if key is None else self.callable_of(key), reverse=bool(kwargs.get("reverse")))
                return None
            if name in ("extend", "insert", "append"):
                extra = len(self.iterate(args[0], "extend's items")) if name == "extend" and args else 1
                m.length(len(obj) + extra, "a list")
                if name == "extend" and args:
                    args = [self.iterate(args[0])]
        elif t is dict and name == "update":
            for a in args:
                m.length(len(obj) + (len(a) if isinstance(a, (dict, list, tuple)) else 0), "a dict")
            m.length(len(obj) + len(kwargs), "a dict")
        elif t in (set, frozenset) and name in ("union", "update", "symmetric_difference"):
            m.length(len(obj) + sum(len(self.iterate(a)) for a in args), "a set")
            args = [self.iterate(a) for a in args]
        for a in args:
            if type(a) in (Function, Lambda, Method):
                raise ExprError(f"{t.__name__}.{name} cannot take a function")
        result = getattr(obj, name)(*args, **kwargs)
        return self.check_size(result, f"the result of {name}")

    # ------------------------------------------------------------------ comprehensions
    def _comprehension(self, node: Any, env: _Env, emit: Callable[[_Env], None]) -> None:
        gens = node.generators

        def loop(i: int, env_i: _Env) -> None:
            if i == len(gens):
                emit(env_i)
                return
            g = gens[i]
            if g.is_async:
                raise ExprError("async comprehensions are not allowed")
            for item in self.iterate(self._eval(g.iter, env_i), "a comprehension's items"):
                self.meter.tick()
                inner = _Env({}, env_i, env_i.scope)
                self._bind(g.target, item, inner.vars)
                if all(self._eval(c, inner) for c in g.ifs):
                    loop(i + 1, inner)

        loop(0, env)

    def _bind(self, target: ast.AST, value: Any, into: dict) -> None:
        if type(target) is ast.Name:
            if target.id.startswith("__"):
                raise ExprError(f"name '{target.id}' is not allowed")
            into[target.id] = value
        elif type(target) in (ast.Tuple, ast.List):
            items = self.iterate(value, "an unpacked value")
            if len(items) != len(target.elts):
                raise ExprError(f"cannot unpack {len(items)} values into {len(target.elts)}")
            for t, v in zip(target.elts, items):
                self._bind(t, v, into)
        else:
            raise ExprError(f"{type(target).__name__} is not allowed as a loop target")

    def _listcomp(self, node: Any, env: _Env) -> list:
        out: list = []

        def emit(e: _Env) -> None:
            out.append(self._eval(node.elt, e))
            self.meter.length(len(out), "a comprehension")

        self._comprehension(node, env, emit)
        return out

    def _setcomp(self, node: ast.SetComp, env: _Env) -> set:
        return set(self._listcomp(node, env))

    def _dictcomp(self, node: ast.DictComp, env: _Env) -> dict:
        out: dict = {}

        def emit(e: _Env) -> None:
            out[self._eval(node.key, e)] = self._eval(node.value, e)
            self.meter.length(len(out), "a comprehension")

        self._comprehension(node, env, emit)
        return out

    # ------------------------------------------------------------------ f-strings
    def _joinedstr(self, node: ast.JoinedStr, env: _Env) -> str:
        parts = [self._eval(v, env) for v in node.values]
        self.meter.length(sum(len(p) for p in parts), "an f-string")
        return "".join(parts)

    def _formatted(self, node: ast.FormattedValue, env: _Env) -> str:
        value = self._eval(node.value, env)
        if node.conversion == ord("r"):
            value = repr(value)
        elif node.conversion == ord("s"):
            value = str(value)
        elif node.conversion == ord("a"):
            value = ascii(value)
        spec = self._eval(node.format_spec, env) if node.format_spec is not None else ""
        _format_spec_ok(spec)
        return self.check_size(format(value, spec), "a formatted value")


def _int_bits(v: Any) -> int:
    return abs(v).bit_length() if type(v) in (int, bool) else 0


def _check_binop(ev: Evaluator, op: type, a: Any, b: Any) -> None:
    """Refuse, before computing, what would be too large."""
    m = ev.meter
    ta, tb = type(a), type(b)
    if op is ast.Mult:
        if ta in (int, bool) and tb in (int, bool):
            if _int_bits(a) + _int_bits(b) > MAX_INT_BITS:
                raise BudgetExceeded(f"xacro expression stopped: a product over {MAX_INT_BITS} bits")
            return
        for seq, n in ((a, b), (b, a)):
            if isinstance(seq, (str, list, tuple)) and type(n) in (int, bool):
                m.length(len(seq) * max(0, n), "a repeated sequence")
    elif op is ast.Add:
        if isinstance(a, (str, list, tuple)) and isinstance(b, (str, list, tuple)):
            m.length(len(a) + len(b), "a concatenation")
    elif op is ast.Pow:
        if ta in (int, bool) and tb in (int, bool) and b > 0 and abs(a) > 1:
            if _int_bits(a) * b > MAX_INT_BITS:
                raise BudgetExceeded(f"xacro expression stopped: a power over {MAX_INT_BITS} bits")
    elif op is ast.LShift:
        if ta in (int, bool) and tb in (int, bool) and _int_bits(a) + max(0, b) > MAX_INT_BITS:
            raise BudgetExceeded(f"xacro expression stopped: a shift over {MAX_INT_BITS} bits")
    elif op is ast.Mod and ta is str:
        _check_percent(a)


_BINOPS: dict[type, Callable[[Any, Any], Any]] = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
    ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod, ast.Pow: operator.pow, ast.LShift: operator.lshift,
    ast.RShift: operator.rshift, ast.BitOr: operator.or_, ast.BitXor: operator.xor, ast.BitAnd: operator.and_,
}
_COMPARE: dict[type, Callable[[Any, Any], bool]] = {
    ast.Eq: operator.eq, ast.NotEq: operator.ne, ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt,
    ast.GtE: operator.ge, ast.Is: operator.is_, ast.IsNot: operator.is_not,
}

# math functions that can take a very long time on large integers, with their largest argument
GUARDED_MATH = {"factorial": 10000, "comb": 10000, "perm": 10000}


def math_function(name: str) -> Function:
    """math.NAME for expressions (integer-heavy ones bounded)."""
    native = getattr(math, name)
    limit = GUARDED_MATH.get(name)

    def impl(ev: Evaluator, args: list, kwargs: dict) -> Any:
        if limit is not None:
            for a in args:
                if type(a) in (int, bool) and abs(a) > limit:
                    raise ExprError(f"math.{name} of {a} is refused (largest argument {limit})")
        if name in ("prod", "fsum", "dist", "hypot", "sumprod"):
            args = [ev.iterate(a) if isinstance(a, _ITERABLE) else a for a in args]
            if name == "prod":
                result: Any = kwargs.get("start", 1)
                for x in args[0]:
                    result = ev.binop(ast.Mult, result, x)
                return result
        for a in args:
            if type(a) is int and a.bit_length() > MAX_INT_BITS:
                raise ExprError(f"math.{name}: argument too large")
        return ev.check_size(native(*args, **kwargs), f"math.{name}")

    return Function(name, impl)
