"""xacro's processing of a model: properties, macros, includes, conditionals, substitution args.

Written from xacro's documentation and behaviour (in-order processing, lazy properties, dynamic macro
scopes, ``^`` forwarding, ``*``/``**`` blocks, ``scope="parent"|"global"``, ``ns=`` includes) so that
real robot models expand to the same URDF; what differs is what a model may do: expressions go to
the restricted evaluator, files are read through ``FilePolicy``, the environment is only what the
caller passed, and every expansion is metered. Nesting of macros, includes and elements is bounded.
"""
from __future__ import annotations

import keyword
import os
import re
from typing import Any

from . import dom
from .budget import Budget, Meter
from .dom import Element, Text
from .errors import BudgetExceeded, XacroError
from .evaluator import Evaluator, ExprError, Function
from .files import FilePolicy
from .symbols import NameSpace, Table, YamlDict, make_globals, math_names, wrap
from .yaml_safe import load_yaml_text

__all__ = ["Processor", "expand", "MAX_MACRO_DEPTH", "MAX_INCLUDE_DEPTH"]

#: Deepest nesting of macro calls (xacro itself stops at Python's recursion limit, about 150).
MAX_MACRO_DEPTH = 200
#: Deepest nesting of includes.
MAX_INCLUDE_DEPTH = 64
#: Most warnings kept (``xacro.warning``, unknown attributes...).
MAX_WARNINGS = 50
_KEYWORDS = frozenset(keyword.kwlist)
_XML_NAME = re.compile(r"^[^\W\d][\w.\-:]*$")
_SUBST = re.compile(r"\$\(([^)]*)\)")
_VALID_COMMANDS = ("find", "env", "optenv", "dirname", "arg", "eval", "cwd")
# a macro parameter spec: NAME[:=|=][^|^|]DEFAULT, the default a ${...} or $(...) token or a run of
# quoted or unspaced text (quotes kept: they make the value a string literal)
_PARAM = re.compile(r"""^\s*([^\s:=]+?)\s*:?=\s*(\^\|?)?(\$\{.*?\}|\$\(.*?\)|(?:'.*?'|".*?"|[^\s'"]+)+|)(?:\s+|$)(.*)""",
                    re.S)


class Macro:
    __slots__ = ("name", "body", "params", "defaults", "file")

    def __init__(self, name: str, body: Element, params: list[str], defaults: dict[str, tuple], file: str | None):
        self.name, self.body, self.params, self.defaults, self.file = name, body, params, defaults, file


def parse_params(spec: str) -> tuple[list[str], dict[str, tuple[str | None, str | None]]]:
    """Macro ``params``: names in order and {name: (forwarded name or None, default text or None)}."""
    params: list[str] = []
    defaults: dict[str, tuple[str | None, str | None]] = {}
    rest = spec
    while rest.strip():
        m = _PARAM.match(rest)
        if m:
            name, forward, default, rest = m.groups()
            params.append(name)
            defaults[name] = (name if forward else None, default or None)
        else:
            parts = rest.split(None, 1)
            params.append(parts[0])
            rest = parts[1] if len(parts) > 1 else ""
    return params, defaults


def boolean(value: Any, text: str | None) -> bool:
    """xacro's truth of a condition: true/True/false/False, an integer, or a typed value."""
    try:
        if type(value) is str:
            if value in ("true", "True"):
                return True
            if value in ("false", "False"):
                return False
            return bool(int(value))
        return bool(value)
    except (ValueError, TypeError):
        raise XacroError(f'condition "{text}" evaluated to "{value}", which is not a boolean') from None


def _auto(value: str) -> Any:
    """$(eval)'s reading of an argument: number, boolean or text."""
    try:
        return float(value) if "." in value else int(value)
    except ValueError:
        pass
    if value.lower() in ("true", "false"):
        return value.lower() == "true"
    return value


class Processor:
    """Expands one model; ``warnings`` collects what xacro would print as warnings."""

    def __init__(self, files: FilePolicy, meter: Meter, args: dict[str, str], env: dict[str, str],
                 cwd: str) -> None:
        self.files = files
        self.meter = meter
        self.args = dict(args)
        self.env = dict(env)
        self.cwd = cwd
        self.ev = Evaluator(meter)
        self.filestack: list[str] = []
        self.macro_depth = 0
        self.depth = 0
        self.warnings: list[str] = []
        self.globals = make_globals(self._xacro_functions())

    # ------------------------------------------------------------------ messages
    def warn(self, text: str) -> None:
        if len(self.warnings) < MAX_WARNINGS:
            where = f" ({self.filestack[-1]})" if self.filestack else ""
            self.warnings.append(text + where)

    def _error(self, text: str, el: Element | None = None) -> XacroError:
        return XacroError(text, el.file if el is not None else (self.filestack[-1] if self.filestack else None),
                          el.line if el is not None else None)

    # ------------------------------------------------------------------ entry
    def process_file(self, path: str) -> Element:
        path = os.path.abspath(path)
        try:
            data = self.files.read(path, "model")
        except FileNotFoundError:
            raise XacroError("no such file", path) from None
        root = dom.parse(data, path, self.meter)
        self.filestack.append(path)
        try:
            target = root.attrs.pop("xacro:targetNamespace", None)
            if target:
                root.attrs["xmlns"] = target
            self.eval_all(root, Table(warn=self.warn), Table(self.globals, resolver=self._resolve, warn=self.warn))
        except RecursionError:
            raise XacroError("the model nests macros, properties or expressions too deeply", path) from None
        finally:
            self.filestack.pop()
        return root

    def _resolve(self, raw: str, table: Table) -> Any:
        """A lazy property's value, evaluated in the scope that holds it."""
        return self.eval_text(raw, table)

    # ------------------------------------------------------------------ text and expressions
    def eval_text(self, text: str, symbols: Table) -> Any:
        """Text with ${expressions} and $(substitutions): a typed value when the text is exactly one of
        them, else the joined string."""
        if "$" not in text:
            return text
        tokens: list[Any] = []
        i, n = 0, len(text)
        while i < n:
            j = text.find("$", i)
            if j < 0:
                tokens.append(text[i:])
                break
            if j > i:
                tokens.append(text[i:j])
            k = j
            while k < n and text[k] == "$":
                k += 1
            nxt = text[k] if k < n else ""
            run = k - j
            if run >= 2:  # $${ is a literal ${ (one $ dropped); other runs of $ are text
                if nxt in ("{", "("):
                    tokens.append("$" * (run - 1) + nxt)
                    i = k + 1
                else:
                    tokens.append(text[j:k])
                    i = k
                continue
            if nxt == "{":
                end = text.find("}", k + 1)
                if end < 0:
                    raise XacroError(f"invalid expression: no closing '}}' in {text!r}")
                tokens.append(self._expression(text[k + 1:end], symbols))
                i = end + 1
            elif nxt == "(":
                end = text.find(")", k + 1)
                if end < 0:
                    raise XacroError(f"invalid substitution: no closing ')' in {text!r}")
                tokens.append(self._substitution(text[k + 1:end], symbols))
                i = end + 1
            else:
                tokens.append("$")
                i = k
            self.meter.tick()
        if len(tokens) == 1:
            return tokens[0]
        out = "".join(t if type(t) is str else str(t) for t in tokens)
        self.meter.length(len(out), "a text")
        return out

    def _expression(self, inner: str, symbols: Table) -> Any:
        code = self.eval_text(inner, symbols)
        try:
            return self.ev.evaluate(code if type(code) is str else str(code), symbols)
        except BudgetExceeded:
            raise
        except XacroError as e:
            raise XacroError(f"{e.message} (when evaluating expression '{inner}')", e.file, e.line) from None

    def _substitution(self, inner: str, symbols: Table) -> str:
        s = self.eval_text(inner, symbols)
        s = s if type(s) is str else str(s)
        if s == "cwd":
            return self.cwd
        if s.startswith("eval "):
            return self._eval_subst(s[5:])
        parts = [p for p in s.split(" ") if p]
        if not parts or parts[0] not in _VALID_COMMANDS:
            raise XacroError(f"unknown substitution command $({s}) (valid: find, arg, env, optenv, dirname, eval, cwd)")
        cmd, rest = parts[0], parts[1:]
        if cmd == "arg":
            if len(rest) != 1:
                raise XacroError(f"$(arg NAME) takes one name, got $({s})")
            if rest[0] not in self.args:
                raise XacroError(f"undefined substitution argument '{rest[0]}' (give it with --xacro-arg "
                                 f"{rest[0]}:=VALUE)")
            return self._finds_in(self.args[rest[0]])
        if cmd == "find":
            if len(rest) != 1:
                raise XacroError(f"$(find PKG) takes one package name, got $({s})")
            return self.files.find(rest[0])
        if cmd == "env":
            if len(rest) != 1:
                raise XacroError(f"$(env VAR) takes one name, got $({s})")
            if rest[0] not in self.env:
                raise XacroError(f"environment variable {rest[0]} is not set or not passed to the model "
                                 f"(models see only the variables named with --xacro-env)")
            return self.env[rest[0]]
        if cmd == "optenv":
            if not rest:
                raise XacroError("$(optenv VAR [default]) needs a name")
            return self.env.get(rest[0], " ".join(rest[1:]))
        if cmd == "dirname":
            return os.path.dirname(self.filestack[-1]) if self.filestack else self.cwd
        raise XacroError(f"$({s}) is not supported")

    def _finds_in(self, value: str) -> str:
        """$(find ...) inside an argument's value is resolved too (xacro does so)."""
        def one(m: re.Match) -> str:
            parts = [p for p in m.group(1).split(" ") if p]
            if not parts or parts[0] not in _VALID_COMMANDS:
                raise XacroError(f"unknown substitution command $({m.group(1)})")
            if parts[0] == "find" and len(parts) == 2:
                return self.files.find(parts[1])
            return m.group(0)
        return _SUBST.sub(one, value) if "$(" in value else value

    def _eval_subst(self, code: str) -> str:
        """$(eval EXPR): the expression with the arguments as names (and arg(), env(), optenv(), find())."""
        if "__" in code:
            raise XacroError("$(eval ...) may not contain double underscores")
        fns = {
            "arg": Function("arg", lambda ev, a, kw: _auto(self._subst_arg(a))),
            "dirname": Function("dirname", lambda ev, a, kw: os.path.dirname(self.filestack[-1])
                                if self.filestack else self.cwd),
            "env": Function("env", lambda ev, a, kw: self._substitution("env " + str(a[0]), Table(self.globals))),
            "optenv": Function("optenv", lambda ev, a, kw: self.env.get(str(a[0]), str(a[1]) if len(a) > 1 else "")),
            "find": Function("find", lambda ev, a, kw: self.files.find(str(a[0]))),
        }
        g = self.globals.names
        base = {"true": True, "false": False, "True": True, "False": False, **math_names(),
                **{k: g[k] for k in ("list", "dict", "map", "str", "float", "int")}, **fns}
        scope = _EvalScope(base, self.args)
        try:
            return str(self.ev.evaluate(code, scope))
        except BudgetExceeded:
            raise
        except XacroError as e:
            raise XacroError(f"{e.message} (in $(eval {code}))") from None

    def _subst_arg(self, a: list) -> str:
        if len(a) != 1 or str(a[0]) not in self.args:
            raise ExprError(f"undefined substitution argument {a[0] if a else ''!r}")
        return self.args[str(a[0])]

    # ------------------------------------------------------------------ xacro.* functions
    def _xacro_functions(self) -> dict[str, Function]:
        def load_yaml(ev: Evaluator, args: list, kwargs: dict) -> Any:
            if len(args) != 1 or type(args[0]) is not str:
                raise ExprError("xacro.load_yaml(FILENAME) takes one file name")
            path = self._abs(args[0])
            try:
                data = self.files.read(path, "YAML file")
            except FileNotFoundError:
                raise ExprError(f"xacro.load_yaml: no such file '{path}'") from None
            text = data.decode("utf-8", "replace")
            self.filestack.append(path)
            try:
                return wrap(load_yaml_text(text, lambda t: self.ev.evaluate(t, Table(self.globals)), self.meter.tick))
            finally:
                self.filestack.pop()

        def abs_filename(ev: Evaluator, args: list, kwargs: dict) -> str:
            if len(args) != 1 or type(args[0]) is not str:
                raise ExprError("xacro.abs_filename(NAME) takes one file name")
            return self._abs(args[0])

        def dotify(ev: Evaluator, args: list, kwargs: dict) -> Any:
            if len(args) != 1 or not isinstance(args[0], dict):
                raise ExprError("xacro.dotify(DICT) takes one dict")
            return YamlDict(args[0])

        def arg(ev: Evaluator, args: list, kwargs: dict) -> str:
            if len(args) != 1 or args[0] not in self.args:
                raise ExprError(f"xacro.arg: undefined argument {args[0] if args else ''!r}")
            return self.args[args[0]]

        def say(kind: str):
            def impl(ev: Evaluator, args: list, kwargs: dict) -> str:
                text = " ".join(str(a) for a in args)[:1000]
                if kind != "message":
                    self.warn(f"xacro.{kind}: {text}")
                return ""
            return impl

        def fatal(ev: Evaluator, args: list, kwargs: dict) -> str:
            raise XacroError(" ".join(str(a) for a in args)[:1000])

        def tokenize(ev: Evaluator, args: list, kwargs: dict) -> list:
            s = args[0] if args else kwargs.get("s")
            sep = args[1] if len(args) > 1 else kwargs.get("sep", ",; ")
            skip = args[2] if len(args) > 2 else kwargs.get("skip_empty", True)
            if type(s) is not str or type(sep) is not str or not sep:
                raise ExprError("xacro.tokenize(TEXT, SEPARATORS=',; ', skip_empty=True) takes strings")
            parts = re.split("[" + re.escape(sep) + "]", s)
            return [p for p in parts if p] if skip else parts

        return {"load_yaml": Function("load_yaml", load_yaml), "abs_filename": Function("abs_filename", abs_filename),
                "dotify": Function("dotify", dotify), "arg": Function("arg", arg),
                "message": Function("message", say("message")), "warning": Function("warning", say("warning")),
                "error": Function("error", say("error")), "print_location": Function("print_location", say("message")),
                "fatal": Function("fatal", fatal), "tokenize": Function("tokenize", tokenize)}

    def _abs(self, spec: str) -> str:
        if os.path.isabs(spec):
            return spec
        base = os.path.dirname(self.filestack[-1]) if self.filestack else self.cwd
        return os.path.join(base, spec)

    # ------------------------------------------------------------------ the tree
    def _attrs(self, el: Element, required: tuple[str, ...], optional: tuple[str, ...]) -> list[str | None]:
        """xacro's check_attrs: the required ones (error if missing), the optional ones, a warning for others."""
        out: list[str | None] = []
        for name in required:
            if name not in el.attrs:
                raise self._error(f"<{el.tag}>: missing required attribute '{name}'", el)
            out.append(el.attrs[name])
        out.extend(el.attrs.get(name) for name in optional)
        extra = [a for a in el.attrs if a not in required and a not in optional and not a.startswith("xmlns:")]
        if extra:
            self.warn(f"{el.tag}: unknown attribute(s): {', '.join(extra)}")
        return out

    def eval_all(self, node: Element, macros: Table, symbols: Table) -> None:
        """Expand ``node`` in place: its attributes, then its children in order."""
        self.depth += 1
        try:
            if self.depth > dom.MAX_DEPTH + MAX_MACRO_DEPTH:
                raise self._error("the model nests elements and macros too deeply", node)
            for name in list(node.attrs):
                if name.startswith("xacro:"):
                    del node.attrs[name]
                else:
                    try:
                        node.attrs[name] = self._str(self.eval_text(node.attrs[name], symbols))
                    except BudgetExceeded:
                        raise
                    except XacroError as e:
                        raise e.at(node.file, node.line) from None
            node.attrs.pop("xmlns:xacro", None)
            out: list = []
            eval_comments = False
            for child in node.children:
                t = type(child)
                if t is Element:
                    eval_comments = False
                    try:
                        self._element(child, node, macros, symbols, out)
                    except BudgetExceeded:
                        raise
                    except XacroError as e:
                        raise e.at(child.file, child.line) from None
                elif t is Text:
                    if "$" in child.data:
                        child.data = self._str(self.eval_text(child.data, symbols))
                    if child.data.strip():
                        eval_comments = False
                    out.append(child)
                else:
                    if "xacro:eval-comments" in child.data:
                        eval_comments = "xacro:eval-comments:off" not in child.data
                        continue
                    if eval_comments:
                        child.data = self._str(self.eval_text(child.data, symbols))
                    out.append(child)
            node.children = out
        finally:
            self.depth -= 1

    def _str(self, value: Any) -> str:
        s = value if type(value) is str else str(value)
        self.meter.length(len(s), "a text")
        return s

    def _element(self, el: Element, parent: Element, macros: Table, symbols: Table, out: list) -> None:
        tag = el.tag
        while tag == "xacro:element":
            name, = self._attrs(el, ("xacro:name",), ())
            name = self._str(self.eval_text(name, symbols))
            if not name or not _XML_NAME.match(name):
                raise self._error(f"xacro:element: {name!r} is not an element name", el)
            del el.attrs["xacro:name"]
            el.tag = tag = name
        if tag == "xacro:insert_block":
            self._insert_block(el, macros, symbols, out)
        elif tag == "xacro:include":
            self._include(el, parent, macros, symbols, out)
        elif tag == "xacro:property":
            self._property(el, symbols)
        elif tag == "xacro:macro":
            self._macro(el, macros)
        elif tag == "xacro:arg":
            name, default = self._attrs(el, ("name", "default"), ())
            if name not in self.args:
                self.args[name] = self._str(self.eval_text(default, symbols))
        elif tag == "xacro:attribute":
            name, value = self._attrs(el, ("name", "value"), ())
            name = self._str(self.eval_text(name, symbols))
            if not name or not _XML_NAME.match(name):
                raise self._error(f"xacro:attribute: {name!r} is not an attribute name", el)
            parent.attrs[name] = self._str(self.eval_text(value, symbols))
        elif tag in ("xacro:if", "xacro:unless"):
            cond, = self._attrs(el, ("value",), ())
            keep = boolean(self.eval_text(cond, symbols), cond)
            if tag == "xacro:unless":
                keep = not keep
            if keep:
                self.eval_all(el, macros, symbols)
                out.extend(el.children)
        elif tag.startswith("xacro:"):
            self._call(el, parent, macros, symbols, out)
        else:
            self.eval_all(el, macros, symbols)
            out.append(el)

    def _insert_block(self, el: Element, macros: Table, symbols: Table, out: list) -> None:
        name, = self._attrs(el, ("name",), ())
        if symbols.contains("**" + name):
            block, content_only = symbols.lookup("**" + name), True
        elif symbols.contains("*" + name):
            block, content_only = symbols.lookup("*" + name), False
        else:
            raise self._error(f'undefined block "{name}"', el)
        if type(block) is not Element:
            raise self._error(f'"{name}" is not a block', el)
        block = dom.clone(block, self.meter)
        self.eval_all(block, macros, symbols)
        if content_only:
            out.extend(block.children)
        else:
            out.append(block)

    def _include(self, el: Element, parent: Element, macros: Table, symbols: Table, out: list) -> None:
        spec, ns, optional = self._attrs(el, ("filename",), ("ns", "optional"))
        if ns:
            ns = self._str(self.eval_text(ns, symbols))
            ns_macros: Table = NameSpace(warn=self.warn)
            macros.set(ns, ns_macros, unevaluated=False)
            ns_symbols: Table = NameSpace(symbols)
            symbols.set(ns, ns_symbols, unevaluated=False)
        else:
            ns_macros, ns_symbols = macros, symbols
        is_optional = boolean(optional, optional) if optional is not None else False
        if el.elements():
            self.warn("child elements of a <xacro:include> tag are ignored")
        filename = self._abs(self._str(self.eval_text(spec, symbols)))
        if len(self.filestack) >= MAX_INCLUDE_DEPTH:
            raise self._error(f"includes nested deeper than {MAX_INCLUDE_DEPTH} (does a file include itself?)", el)
        if re.search(r"[*[?]", filename):
            names = self.files.glob(filename)
            if not names:
                self.warn(f'include pattern "{filename}" matched no files')
        else:
            names = [filename]
        for name in names:
            try:
                data = self.files.read(name, "included file")
            except FileNotFoundError:
                if is_optional:
                    continue
                raise self._error(f"included file not found: {name}", el) from None
            root = dom.parse(data, name, self.meter)
            self.filestack.append(name)
            try:
                self.eval_all(root, ns_macros, ns_symbols)
            finally:
                self.filestack.pop()
            self._import_namespaces(parent, root)
            out.extend(root.children)

    def _import_namespaces(self, parent: Element, src: Element) -> None:
        for name, value in src.attrs.items():
            if name.startswith("xmlns:"):
                old = parent.attrs.get(name)
                if old is not None and old != value:
                    self.warn(f"inconsistent namespace redefinitions for {name}")
                else:
                    parent.attrs[name] = value

    def _property(self, el: Element, table: Table) -> None:
        name, value, default, remove, scope, lazy = self._attrs(el, ("name",),
                                                               ("value", "default", "remove", "scope", "lazy_eval"))
        name = self.eval_text(name, table)
        if type(name) is not str or not name.isidentifier() or name in ("True", "False", "None") \
                or name in _KEYWORDS:
            raise self._error(f"property names must be valid Python identifiers: {name}", el)
        if name.startswith("__"):
            raise self._error(f"property names must not start with double underscore: {name}", el)
        removing = boolean(self.eval_text(remove or "false", table), remove)
        if sum((value is not None, default is not None, removing)) > 1:
            raise self._error(f"property attributes default, value and remove exclude each other: {name}", el)
        if removing:
            if table.contains(name):
                table.delete(name)
            return
        if default is not None:
            if scope is not None:
                self.warn(f"{name}: a default property value can only be defined in the local scope")
            if table.contains(name):
                return
            value = default
        stored: Any = value
        if value is None:  # a block property: its content, inserted with insert_block
            name, stored = "**" + name, el
        lazy_eval = boolean(self.eval_text(lazy or "true", table), lazy)
        if scope == "global":
            target = table.top()
            lazy_eval = False
        elif scope == "parent":
            parent = table.parent
            if not isinstance(parent, Table):
                self.warn(f"{name}: no parent scope at global scope")
                return
            target = parent
            lazy_eval = False
            if not table.is_namespace:  # in a macro: the caller's scope, past included namespaces
                while target.is_namespace and isinstance(target.parent, Table):
                    target = target.parent
        else:
            target = table
        if not lazy_eval and type(stored) is str:
            stored = self.eval_text(stored, table)
        target.set(name, stored, unevaluated=lazy_eval)

    def _macro(self, el: Element, macros: Table) -> None:
        name, params = self._attrs(el, ("name",), ("params",))
        if name == "call":
            raise self._error("invalid use of macro name 'call'", el)
        if "." in name:
            raise self._error(f"macro names must not contain '.' (reserved for namespaces): {name}", el)
        if name.startswith("xacro:"):
            self.warn(f"macro names must not contain prefix 'xacro:': {name}")
            name = name[6:]
        names, defaults = parse_params(params or "")
        macros.set(name, Macro(name, el, names, defaults, el.file), unevaluated=False)

    def _resolve_macro(self, fullname: str, macros: Table, symbols: Table) -> tuple[Macro, Table, Table]:
        try:
            m = macros.lookup(fullname)
        except KeyError:
            *spaces, name = fullname.split(".")
            if not spaces:
                raise XacroError(f"unknown macro name: xacro:{fullname}") from None
            try:
                for ns in spaces:
                    macros, symbols = macros.lookup(ns), symbols.lookup(ns)
                m = macros.lookup(name)
            except (KeyError, AttributeError):
                raise XacroError(f"unknown macro name: xacro:{fullname}") from None
        if type(m) is not Macro:
            raise XacroError(f"unknown macro name: xacro:{fullname}")
        return m, macros, symbols

    def _call(self, el: Element, parent: Element, macros: Table, symbols: Table, out: list) -> None:
        if el.tag == "xacro:call":
            name, = self._attrs(el, ("macro",), ())
            name = self._str(self.eval_text(name, symbols))
            if not name:
                raise self._error("xacro:call is missing the 'macro' attribute", el)
            del el.attrs["macro"]
            el.tag = "xacro:" + name
        m, scope_macros, scope_symbols = self._resolve_macro(el.tag[6:], macros, symbols)
        if self.macro_depth >= MAX_MACRO_DEPTH:
            raise self._error(f"macro calls nested deeper than {MAX_MACRO_DEPTH} (does macro '{m.name}' call "
                              f"itself without end?)", el)
        self.macro_depth += 1
        try:
            body = dom.clone(m.body, self.meter)
            local = Table(scope_symbols)
            local_macros = Table(scope_macros)
            params = list(m.params)
            for name in list(el.attrs):
                if name not in params:
                    raise self._error(f'invalid parameter "{name}" of macro \'{m.name}\'', el)
                params.remove(name)
                local.set(name, self.eval_text(el.attrs[name], symbols), unevaluated=False)
                el.attrs[name] = ""
            self.eval_all(el, macros, symbols)  # the blocks given to the macro, in the caller's scope
            blocks = iter(el.elements())
            for p in list(params):
                if p.startswith("*"):
                    block = next(blocks, None)
                    if block is None:
                        raise self._error(f"not enough blocks for macro '{m.name}'", el)
                    params.remove(p)
                    local.set(p, block, unevaluated=True)
            extra = next(blocks, None)
            if extra is not None:
                raise self._error(f'unused block "{extra.tag}" in a call of macro \'{m.name}\'', el)
            for p in list(params):
                if p.startswith("*") or p not in m.defaults:
                    continue
                forward, default = m.defaults[p]
                if forward is None and default is None:
                    continue
                local.set(p, self._default(forward, default, symbols, m), unevaluated=False)
                params.remove(p)
            if params:
                raise self._error(f"undefined parameters [{','.join(params)}] of macro '{m.name}'", el)
            self.eval_all(body, local_macros, local)
            self._import_namespaces(parent, body)
            out.extend(body.children)
        finally:
            self.macro_depth -= 1

    def _default(self, forward: str | None, default: str | None, symbols: Table, m: Macro) -> Any:
        if forward is None:
            return self.eval_text(default or "", symbols)
        try:
            return symbols.lookup(forward)
        except KeyError:
            if default is not None:
                return self.eval_text(default, symbols)
            raise XacroError(f"undefined property to forward: {forward} (macro '{m.name}')") from None


class _EvalScope:
    """$(eval)'s names: its functions and constants, then the arguments themselves (read as numbers when
    they look like numbers)."""

    __slots__ = ("base", "args")

    def __init__(self, base: dict[str, Any], args: dict[str, str]) -> None:
        self.base, self.args = base, args

    def lookup(self, name: str) -> Any:
        if name in self.base:
            return self.base[name]
        return _auto(self.args[name])


def expand(path: str, *, roots: list[str], search: list[str], packages: dict[str, str], args: dict[str, str],
           env: dict[str, str], cwd: str, budget: Budget) -> tuple[str, list[str]]:
    """The URDF text of the model at ``path`` and the warnings; XacroError (one line) when refused."""
    meter = Meter(budget)
    proc = Processor(FilePolicy(roots, search, packages, meter), meter, args, env, cwd)
    root = proc.process_file(path)
    return dom.serialize(root, budget.max_output), proc.warnings
