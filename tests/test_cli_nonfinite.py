"""Every float option and argument of every `zentf` command refuses NaN and ±inf.

The parameters are enumerated from the click tree, so a float option added later is tested (and must
use zentf.cli.common.finite_float) without anyone listing it here.
"""
from __future__ import annotations

import os

import click
import pytest
from cli_helpers import assert_one_line_error, zentf

from zentf.cli import cli
from zentf.cli.common import FiniteFloat, FiniteFloatRange


def _commands(group: click.Group, path: tuple[str, ...] = ()) -> list[tuple[tuple[str, ...], click.Command]]:
    ctx = click.Context(group)
    out = []
    for name in group.list_commands(ctx):
        cmd = group.get_command(ctx, name)
        assert cmd is not None, name
        if isinstance(cmd, click.Group):
            out += _commands(cmd, (*path, name))
        else:
            out.append(((*path, name), cmd))
    return out


def _float_params() -> list[tuple[tuple[str, ...], click.Command, click.Parameter]]:
    return [(path, cmd, p) for path, cmd in _commands(cli) for p in cmd.params
            if isinstance(p.type, click.types.FloatParamType)]


FLOAT_PARAMS = _float_params()


def _placeholder(p: click.Parameter) -> str:
    if isinstance(p.type, click.Choice):
        return str(p.type.choices[-1])
    if isinstance(p.type, click.types.FloatParamType):
        return "1"
    return "x"


def _argv(path: tuple[str, ...], cmd: click.Command, target: click.Parameter, value: str) -> list[str]:
    """The command line that reaches ``target`` with ``value``: placeholders for the arguments before it."""
    args = [p for p in cmd.params if isinstance(p, click.Argument)]
    positional: list[str] = []
    for p in args:
        if p is target:
            positional.append(value)
            break
        if p.required or isinstance(target, click.Argument):
            positional.append(_placeholder(p))
    argv = [*path, *positional]
    if isinstance(target, click.Option):
        argv += [target.opts[0], value]
    return argv


def test_the_enumeration_finds_the_float_options_of_every_command_group():
    names = {(" ".join(path), p.name) for path, _, p in FLOAT_PARAMS}
    for expected in [("topic echo", "timeout"), ("topic pub", "wait_matching"), ("launch", "stop_timeout"),
                     ("tf echo", "timeout"), ("topic hz", "duration"), ("bag record", "duration"),
                     ("tf monitor", "duration"), ("node list", "wait"), ("clock", "timeout"),
                     ("clock", "factor"), ("tf echo", "at_time"), ("tf echo", "rate_arg")]:
        assert expected in names, expected
    assert len(FLOAT_PARAMS) >= 20


@pytest.mark.parametrize("path,cmd,param", FLOAT_PARAMS,
                         ids=[f"{' '.join(p)}:{q.name}" for p, _, q in FLOAT_PARAMS])
def test_float_param_uses_the_shared_finite_type(path, cmd, param):
    assert isinstance(param.type, (FiniteFloat, FiniteFloatRange)), (
        f"zentf {' '.join(path)} {param.name}: use zentf.cli.common.finite_float()")


@pytest.fixture(scope="module")
def offline_env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env["PYTHONUNBUFFERED"] = "1"
    return env


@pytest.mark.parametrize("path,cmd,param", FLOAT_PARAMS,
                         ids=[f"{' '.join(p)}:{q.name}" for p, _, q in FLOAT_PARAMS])
def test_nan_is_refused_in_a_real_process(offline_env, path, cmd, param):
    proc = zentf(_argv(path, cmd, param, "nan"), offline_env, timeout=30)
    where = f"'{param.opts[0]}'" if isinstance(param, click.Option) else ""
    line = assert_one_line_error(proc, "Invalid value for ", where, ": nan is not finite", code=2)
    assert proc.stdout == "", line


@pytest.mark.parametrize("value,shown", [("inf", "inf"), ("-inf", "-inf"), ("1e999", "inf"), ("NaN", "nan")])
@pytest.mark.parametrize("path,cmd,param", FLOAT_PARAMS,
                         ids=[f"{' '.join(p)}:{q.name}" for p, _, q in FLOAT_PARAMS])
def test_infinities_are_refused(path, cmd, param, value, shown):
    """In process (the parse is the same code the real process runs above): one error, no hang."""
    from click.testing import CliRunner

    argv = _argv(path, cmd, param, value)
    if isinstance(param, click.Option):  # '--opt=-inf': a leading '-' must not look like an option
        argv[-2:] = [f"{argv[-2]}={argv[-1]}"]
    elif value.startswith("-"):
        argv.insert(len(path), "--")
    result = CliRunner().invoke(cli, argv, catch_exceptions=False)
    assert result.exit_code == 2, (argv, result.output)
    assert f"{shown} is not finite" in result.output, (argv, result.output)


@pytest.mark.parametrize("path,cmd,param", FLOAT_PARAMS,
                         ids=[f"{' '.join(p)}:{q.name}" for p, _, q in FLOAT_PARAMS])
def test_absurd_magnitudes_are_refused(path, cmd, param):
    """1e300 s would overflow a sleep, a wait or a Zenoh timeout ("negative timeout", "time_t")."""
    from click.testing import CliRunner

    argv = _argv(path, cmd, param, "1e300")
    result = CliRunner().invoke(cli, argv, catch_exceptions=False)
    assert result.exit_code == 2, (argv, result.output)
    assert "1e+300 is too large" in result.output or "1e+300 is not a time stamp" in result.output, result.output
