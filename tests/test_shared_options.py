"""The node/Zenoh options are declared once (zentf.transport.options.SHARED_OPTIONS): every `zentf` command,
`zentf --help` and every program's --help show the same flags with the same help, and the CLI takes them
before the subcommand too (`zentf -n robot1 tf echo ...`), a value after the subcommand winning."""
from __future__ import annotations

import os
import subprocess
import sys

import click
import pytest
from cli_helpers import ZENTF, assert_one_line_error, zentf
from conftest import REPO

from zentf.cli import cli
from zentf.tools.programs import PROGRAMS
from zentf.transport.options import SHARED_OPTIONS

CLI_SHARED = [o for o in SHARED_OPTIONS if not o.programs_only]


def _flat(text: str) -> str:
    return " ".join(text.split())


def _commands(group: click.Group, ctx: click.Context, path: tuple[str, ...] = ()) -> list[tuple[tuple[str, ...], click.Command]]:
    out = []
    for name in group.list_commands(ctx):
        cmd = group.get_command(ctx, name)
        if isinstance(cmd, click.Group):
            out += _commands(cmd, ctx, (*path, name))
        elif cmd is not None:
            out.append(((*path, name), cmd))
    return out


def test_every_command_with_shared_options_takes_all_of_them_as_declared() -> None:
    """Each click command that takes one shared option takes every one, with the table's flags and help
    (the pass-through commands hand them to the program, whose parser is built from the same table)."""
    ctx = click.Context(cli)
    checked = 0
    for path, cmd in [((), cli), *_commands(cli, ctx)]:
        params = {p.name: p for p in cmd.params if isinstance(p, click.Option)}
        if not any(o.dest in params for o in SHARED_OPTIONS):
            continue
        checked += 1
        for opt in SHARED_OPTIONS:
            if opt.programs_only:
                assert opt.dest not in params, (path, opt.dest)
                continue
            p = params[opt.dest]
            assert (tuple(p.opts), p.help, p.multiple) == (opt.flags, opt.help_text, opt.kind == "repeat"), path
    assert checked >= 20, checked


@pytest.mark.parametrize("argv", [[], ["tf", "echo"], ["topic", "list"], ["launch"], ["bridge", "ros2"]],
                         ids=["zentf", "tf-echo", "topic-list", "launch", "bridge"])
def test_cli_help_shows_the_shared_options(argv) -> None:
    proc = zentf([*argv, "--help"], None)
    assert proc.returncode == 0, proc.stderr
    text = _flat(proc.stdout)
    for opt in CLI_SHARED:
        assert _flat(opt.help_text) in text and opt.flags[0] in text, (argv, opt.dest, proc.stdout)


@pytest.mark.parametrize("argv", [["run", name] for name in PROGRAMS] +
                         [["robot-state-publisher"], ["joint-state-publisher"], ["static-transform-publisher"]],
                         ids=[*PROGRAMS, "zentf-robot-state-publisher", "zentf-joint-state-publisher",
                              "zentf-static-transform-publisher"])
def test_every_program_help_shows_the_shared_options(argv) -> None:
    proc = zentf([*argv, "--help"], None)
    assert proc.returncode == 0, proc.stderr
    text = _flat(proc.stdout)
    for opt in SHARED_OPTIONS:
        assert _flat(opt.help_text) in text and opt.flags[0] in text, (argv, opt.dest, proc.stdout)


def test_a_thin_runner_shows_them_too() -> None:
    proc = subprocess.run([sys.executable, "-m", "nodes.turtlesim", "--help"], capture_output=True, text=True,
                          timeout=60, cwd=REPO)
    assert proc.returncode == 0, proc.stderr
    for opt in SHARED_OPTIONS:
        assert _flat(opt.help_text) in _flat(proc.stdout), opt.dest


@pytest.fixture
def bare_env() -> dict[str, str]:
    """os.environ without any ZENTF_* variable: the options must come from the command line."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(REPO), env.get("PYTHONPATH", "")) if p)
    env["PYTHONUNBUFFERED"] = "1"
    return env


def test_options_before_the_subcommand_reach_commands_and_programs(spawn, zenoh_router, test_namespace,
                                                                   bare_env) -> None:
    net = ["--connect", zenoh_router, "--mode", "client", "--no-multicast"]
    # a program started by `zentf run` takes them from before `run`
    pub = spawn([*ZENTF, "-n", test_namespace, *net, "run", "static_transform_publisher",
                 "1", "2", "3", "0", "0", "0", "world", "thing"], env=bare_env)
    pub.wait_for_line("world", 30)
    echo = ["tf", "echo", "world", "thing", "--count", "1", "--timeout", "20"]
    before = zentf(["-n", test_namespace, *net, *echo], bare_env)
    assert before.returncode == 0 and "Translation: [1.000, 2.000, 3.000]" in before.stdout, before.stderr
    # after the subcommand wins over before it
    after = zentf(["-n", "somewhere_else", *net, *echo, "-n", test_namespace], bare_env)
    assert after.returncode == 0 and "Translation: [1.000, 2.000, 3.000]" in after.stdout, after.stderr
    # and the namespace before the subcommand is the one used (not found elsewhere)
    elsewhere = zentf(["-n", "somewhere_else", *net, "tf", "echo", "world", "thing", "--timeout", "2"], bare_env)
    assert_one_line_error(elsewhere, "no transform world -> thing")


def test_a_bad_value_before_the_subcommand_is_one_line() -> None:
    assert_one_line_error(zentf(["--mode", "boss", "tf", "frames"], None), "--mode", code=2)
    assert_one_line_error(zentf(["--wire", "dds", "node", "list"], None), "--wire", code=2)


def test_the_architecture_table_lists_every_shared_option() -> None:
    table = (REPO / "docs" / "architecture.md").read_text().split("## How a node learns its identity")[1]
    for opt in SHARED_OPTIONS:
        assert f"`{opt.flags[0]}" in table and f"`{opt.env}" in table, opt.dest
