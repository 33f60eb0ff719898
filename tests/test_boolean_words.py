"""One reading of yes/no words: environment variables, node parameters, launch conditions and the CLI's
ZENTF_DEBUG take the same words (true/yes/on/1, false/no/off/0, empty = false) and refuse the same others
with one line naming the variable, parameter or key."""
from __future__ import annotations

import subprocess
import sys

import pytest
from cli_helpers import assert_one_line_error, zentf
from conftest import REPO

from zentf.transport.node import Parameter
from zentf.core.text import parse_bool
from zentf.launch import load_launch
from zentf.launch.errors import LaunchError
from zentf.transport import program
from zentf.transport.options import NodeOptions, OptionsError

WORDS = [("true", True), ("Yes", True), (" on ", True), ("1", True), (True, True), (1, True),
         ("false", False), ("NO", False), ("off", False), ("0", False), ("", False), (False, False), (0, False)]
BAD = ["maybe", "2", "tru", "y", 2, 0.5, [], None]


class _Params:
    """What program.param_bool asks of a node: declare_parameter(name, default) -> a Parameter."""

    def __init__(self, value: object) -> None:
        self.value = value

    def declare_parameter(self, name: str, default: object) -> Parameter:
        return Parameter(name, self.value)


def _launch_if(tmp_path, word: object) -> bool:
    path = tmp_path / "a.yaml"
    text = word if isinstance(word, str) else str(word).lower() if isinstance(word, bool) else str(word)
    path.write_text(f"nodes:\n  - {{cmd: [true], name: a, if: '{text}'}}\n")
    return bool(load_launch(str(path)).nodes)


@pytest.mark.parametrize("word,expected", WORDS)
def test_every_reader_takes_the_same_words(word, expected, tmp_path) -> None:
    assert parse_bool(word) is expected
    assert program.param_bool(_Params(word), "flag", False) is expected
    if isinstance(word, str):
        assert NodeOptions.from_env({"ZENTF_LAN": word, "ZENTF_NO_MULTICAST": word}).zenoh.lan is expected
        assert NodeOptions.from_env({"ZENTF_NO_MULTICAST": word}).zenoh.no_multicast is expected
    assert _launch_if(tmp_path, word) is expected


@pytest.mark.parametrize("word", BAD)
def test_every_reader_refuses_the_same_words_naming_what(word, tmp_path) -> None:
    with pytest.raises(ValueError, match="expected true or false"):
        parse_bool(word, "x")
    with pytest.raises(OptionsError, match="parameter flag: expected true or false"):
        program.param_bool(_Params(word), "flag", False)
    if isinstance(word, str):
        with pytest.raises(OptionsError, match="ZENTF_LAN: expected true or false"):
            NodeOptions.from_env({"ZENTF_LAN": word})
    if word is not None and not isinstance(word, list):
        with pytest.raises(LaunchError, match="if: expected true or false"):
            _launch_if(tmp_path, word)


def test_use_sim_time_takes_the_words_and_refuses_others(node_options) -> None:
    from zentf.transport.node import Node

    for word, sim in (("on", True), ("no", False)):
        with Node("words", options=node_options.with_(params={"use_sim_time": word})) as node:
            assert node.get_parameter("use_sim_time").value is sim
    with pytest.raises(ValueError, match="parameter use_sim_time: expected true or false"):
        Node("words", options=node_options.with_(params={"use_sim_time": "sometimes"}))


def test_zentf_debug_is_read_with_the_same_words() -> None:
    """ZENTF_DEBUG=false no longer means debug (any non-empty value but 0 did); a word it does not know is
    one line, exit 2, for zentf and for zentf-launch alike."""
    import os

    env = {k: v for k, v in os.environ.items() if not k.startswith("ZENTF_")}
    missing = str(REPO / "nowhere.urdf")
    quiet = zentf(["urdf", "check", missing], {**env, "ZENTF_DEBUG": "false"})
    assert_one_line_error(quiet, "nowhere.urdf")
    loud = zentf(["urdf", "check", missing], {**env, "ZENTF_DEBUG": "yes"})
    assert "Traceback" in loud.stderr, loud.stderr
    assert_one_line_error(zentf(["urdf", "check", missing], {**env, "ZENTF_DEBUG": "sometimes"}),
                          "ZENTF_DEBUG: expected true or false", code=2)
    launch = subprocess.run([sys.executable, "-m", "zentf.launch", "--help"], env={**env, "ZENTF_DEBUG": "sometimes"},
                            capture_output=True, text=True, timeout=60, cwd=REPO)
    assert launch.returncode == 2 and "ZENTF_DEBUG: expected true or false" in launch.stderr, launch.stderr
