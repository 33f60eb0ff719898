"""`$(arg x)`, `$(env VAR default)`, `$(optenv VAR default)` and `$(dirname)` inside launch-file strings."""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Callable, Mapping

__all__ = ["SubstitutionContext", "SubstitutionError", "substitute", "has_substitution", "KINDS"]


class SubstitutionError(ValueError):
    """A `$(...)` that cannot be resolved; the message says which and why."""


@dataclass
class SubstitutionContext:
    """What substitutions can see: declared args, the launch file's directory, the environment."""

    args: Mapping[str, str]
    dirname: str
    environ: Mapping[str, str] = field(default_factory=lambda: os.environ)


def _arg(ctx: SubstitutionContext, params: list[str]) -> str:
    if len(params) != 1:
        raise SubstitutionError(f"$(arg NAME) takes one name, got {len(params)}")
    name = params[0]
    if name not in ctx.args:
        known = ", ".join(sorted(ctx.args)) or "none declared"
        raise SubstitutionError(f"unknown argument {name!r} in $(arg {name}) (declared: {known})")
    return ctx.args[name]


def _env(ctx: SubstitutionContext, params: list[str]) -> str:
    if not 1 <= len(params) <= 2:
        raise SubstitutionError("$(env VAR [DEFAULT]) takes a variable name and an optional default")
    value = ctx.environ.get(params[0])
    if value is None:
        if len(params) == 1:
            raise SubstitutionError(f"environment variable {params[0]!r} is not set and $(env) has no default")
        return params[1]
    return value


def _optenv(ctx: SubstitutionContext, params: list[str]) -> str:
    if not 1 <= len(params) <= 2:
        raise SubstitutionError("$(optenv VAR [DEFAULT]) takes a variable name and an optional default")
    return ctx.environ.get(params[0], params[1] if len(params) == 2 else "")


def _dirname(ctx: SubstitutionContext, params: list[str]) -> str:
    if params:
        raise SubstitutionError("$(dirname) takes no arguments")
    return ctx.dirname


KINDS: dict[str, Callable[[SubstitutionContext, list[str]], str]] = {
    "arg": _arg, "env": _env, "optenv": _optenv, "dirname": _dirname,
}


def has_substitution(text: str) -> bool:
    return "$(" in text


def substitute(text: str, ctx: SubstitutionContext) -> str:
    """Resolve every `$(...)` in text (nesting allowed: `$(env X $(arg y))`)."""
    out, pos = _parse(text, 0, ctx, nested=False)
    return out


def _parse(text: str, pos: int, ctx: SubstitutionContext, nested: bool) -> tuple[str, int]:
    """Expand text from pos; when nested, stop at the `)` closing the current `$(`."""
    out: list[str] = []
    n = len(text)
    while pos < n:
        if text.startswith("$(", pos):
            value, pos = _one(text, pos + 2, ctx)
            out.append(value)
        elif nested and text[pos] == ")":
            return "".join(out), pos
        else:
            out.append(text[pos])
            pos += 1
    if nested:
        raise SubstitutionError(f"unclosed '$(' in {text!r}")
    return "".join(out), pos


def _one(text: str, pos: int, ctx: SubstitutionContext) -> tuple[str, int]:
    """Expand one `$(kind params...)` whose body starts at pos; return (value, position after ')')."""
    body, end = _parse(text, pos, ctx, nested=True)
    words = body.split()
    if not words:
        raise SubstitutionError(f"empty substitution '$()' in {text!r}")
    kind, params = words[0], words[1:]
    fn = KINDS.get(kind)
    if fn is None:
        raise SubstitutionError(f"unknown substitution '$({kind} ...)' (known: {', '.join(KINDS)})")
    return fn(ctx, params), end + 1
