""".xacro models: real robots expand to the URDF the xacro package makes; hostile ones run nothing,
write nothing, read nothing outside their folder and package paths, and stop within a budget.

The xacro package (a test-only dependency) is the reference, run in its own process by
tests/xacro_reference.py, and only on files where it is safe to run.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap
import time
import xml.etree.ElementTree as ET
from dataclasses import replace
from pathlib import Path

import pytest

from cli_helpers import assert_one_line_error, zentf
from conftest import REPO
from zentf.urdf import URDFError, load_urdf, parse_urdf, read_urdf_text

DATA = REPO / "tests" / "data" / "urdf"
REFERENCE = str(REPO / "tests" / "xacro_reference.py")
XACRO_NS = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'


def _need_xacro() -> None:
    try:
        import xacro  # noqa: F401
    except ImportError:
        if os.environ.get("CI"):
            raise
        pytest.skip("the xacro package (test extra) is not installed: no reference to compare with")


def _reference(model: Path, packages: dict[str, Path], args: dict[str, str] | None = None) -> str:
    cmd = [sys.executable, REFERENCE, str(model), *[f"{k}={v}" for k, v in packages.items()], "--",
           *[f"{k}:={v}" for k, v in (args or {}).items()]]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120, cwd=str(model.parent))
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout


def _norm(value: str) -> tuple:
    tokens = value.split()
    try:
        return ("numbers", tuple(float(t) for t in tokens))
    except ValueError:
        return ("text", " ".join(tokens))


def _same_value(a: str, b: str) -> bool:
    na, nb = _norm(a), _norm(b)
    if na[0] != nb[0] or len(na[1]) != len(nb[1]):
        return False
    if na[0] == "text":
        return na[1] == nb[1]
    return all(x == y or math.isclose(x, y, rel_tol=1e-12, abs_tol=1e-300) or (x != x and y != y)
               for x, y in zip(na[1], nb[1]))


def _difference(a: ET.Element, b: ET.Element, path: str = "") -> str | None:
    """The first difference of two documents (tags, attributes with numbers compared as numbers, text,
    children in order; comments and layout whitespace ignored), None when they are the same."""
    here = f"{path}/{a.tag}"
    if a.tag != b.tag:
        return f"{here}: tag {a.tag!r} != {b.tag!r}"
    if set(a.attrib) != set(b.attrib):
        return f"{here}: attributes {sorted(a.attrib)} != {sorted(b.attrib)}"
    for k, v in a.attrib.items():
        if not _same_value(v, b.attrib[k]):
            return f"{here}@{k}: {v!r} != {b.attrib[k]!r}"
    if not _same_value(a.text or "", b.text or ""):
        return f"{here}: text {a.text!r} != {b.text!r}"
    ca, cb = list(a), list(b)
    if [c.tag for c in ca] != [c.tag for c in cb]:
        return f"{here}: children {[c.tag for c in ca]} != {[c.tag for c in cb]}"
    for i, (x, y) in enumerate(zip(ca, cb)):
        d = _difference(x, y, f"{here}[{i}]")
        if d:
            return d
    return None


def _assert_same_urdf(ours: str, reference: str) -> None:
    diff = _difference(ET.fromstring(ours.encode()), ET.fromstring(reference.encode()))
    assert diff is None, diff
    a, b = parse_urdf(ours), parse_urdf(reference)
    assert (a.name, a.root, list(a.links), list(a.joints)) == (b.name, b.root, list(b.links), list(b.joints))
    for name, j in a.joints.items():  # (line numbers differ: the layouts do)
        assert replace(j, line=None) == replace(b.joints[name], line=None), name
    for name, link in a.links.items():
        assert link.visuals == b.links[name].visuals, name


REAL_MODELS = {
    "urdf_tutorial_08": (DATA / "urdf_tutorial" / "urdf" / "08-macroed.urdf.xacro", {}, {}),
    "turtlebot3_burger": (DATA / "turtlebot3_description" / "urdf" / "turtlebot3_burger.urdf.xacro",
                          {"turtlebot3_description": DATA / "turtlebot3_description"}, {}),
    "ur5e": (DATA / "ur_description" / "urdf" / "ur.urdf.xacro", {"ur_description": DATA / "ur_description"},
             {"ur_type": "ur5e", "name": "ur"}),
    "ur5e_prefixed_safety": (DATA / "ur_description" / "urdf" / "ur.urdf.xacro",
                             {"ur_description": DATA / "ur_description"},
                             {"ur_type": "ur5e", "name": "left_ur", "tf_prefix": "left_", "safety_limits": "true"}),
    "franka_fr3": (DATA / "franka_description" / "robots" / "fr3" / "fr3.urdf.xacro",
                   {"franka_description": DATA / "franka_description"}, {}),
    "franka_fr3_no_hand_prefixed": (DATA / "franka_description" / "robots" / "fr3" / "fr3.urdf.xacro",
                                    {"franka_description": DATA / "franka_description"},
                                    {"hand": "false", "arm_prefix": "left", "with_sc": "true"}),
}


@pytest.mark.parametrize("case", list(REAL_MODELS))
def test_real_xacro_models_expand_to_the_urdf_the_xacro_package_makes(case: str) -> None:
    _need_xacro()
    model, packages, args = REAL_MODELS[case]
    reference = _reference(model, packages, args)
    ours = read_urdf_text(str(model), args)  # $(find) by the model's own package.xml, nothing given
    _assert_same_urdf(ours, reference)


def test_real_xacro_models_load_through_the_cli_and_robot_state_publisher(spawn) -> None:
    proc = zentf(["urdf", "check", str(REAL_MODELS["ur5e"][0]), "--xacro-arg", "ur_type:=ur5e",
                  "--xacro-arg", "name:=ur"], None)
    assert proc.returncode == 0, proc.stderr
    assert "root Link: world has 1 child(ren)" in proc.stdout
    robot = load_urdf(REAL_MODELS["ur5e"][0], xacro_args={"ur_type": "ur5e", "name": "ur"})
    assert [j.name for j in robot.actuated_joints()] == ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                                        "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]
    rsp = spawn.python("-m", "nodes.robot_state_publisher", str(REAL_MODELS["franka_fr3"][0]))
    rsp.wait_for_line(r"publishing robot 'fr3' \(\d+ links\)", timeout=60)


# ----------------------------------------------------------------------------- xacro's features
FEATURES = {
    "properties_lazy_and_typed": """
      <xacro:property name="a" value="${b * 2}"/><xacro:property name="b" value="3"/>
      <xacro:property name="s" value="'quoted'"/><xacro:property name="u" value="1_000"/>
      <xacro:property name="t" value="true"/><xacro:property name="y" value="${xacro.load_yaml('data.yaml')}"/>
      <link name="l" a="${a}" s="${s}" u="${u}" t="${t}" f="${1/3}" p="${pi/2}" r="${radians(90)}"
            m="${math.atan2(1, 2)}" x="${'%.3f' % 2.5} ${'%6s|%-4d' % ('ab', a)} ${y.fmt.format(a, w='b')}"/>""",
    "escapes_and_dollars": """<link name="l" b="$${foo}" c="$$${foo}" d="text $${foo}" f="$$(pwd)" g="a $ b" h="$"/>""",
    "macro_params_defaults_forwarding_blocks": """
      <xacro:property name="outer" value="7"/>
      <xacro:macro name="m" params="n:=1 q:=^ w:=^|5 s:='a b' *first **rest">
        <link name="l${n}" q="${q}" w="${w}" s="${s}"><xacro:insert_block name="first"/><xacro:insert_block name="rest"/></link>
      </xacro:macro>
      <xacro:property name="q" value="${outer + 1}"/>
      <xacro:m n="2"><origin xyz="1 2 3"/><rest><a/><b x="${outer}"/></rest></xacro:m>
      <xacro:m><first/><rest/></xacro:m>""",
    "scopes_parent_global_and_remove": """
      <xacro:macro name="setp" params="v"><xacro:property name="fromp" value="${v}" scope="parent"/>
        <xacro:property name="fromg" value="${v * 2}" scope="global"/></xacro:macro>
      <xacro:setp v="4"/>
      <link name="a" p="${fromp}" g="${fromg}"/>
      <xacro:property name="gone" value="1"/><xacro:property name="gone" remove="true"/>
      <xacro:property name="d" default="first"/><xacro:property name="d" default="second"/>
      <link name="b" d="${d}"/>""",
    "conditionals_elements_attributes": """
      <xacro:property name="n" value="3"/>
      <xacro:if value="${n > 2}"><link name="big"/></xacro:if>
      <xacro:unless value="${n > 2}"><link name="small"/></xacro:unless>
      <xacro:if value="true"><link name="t"/></xacro:if><xacro:if value="0"><link name="f"/></xacro:if>
      <xacro:element xacro:name="${'li' + 'nk'}" name="made"><xacro:attribute name="extra" value="v${n}"/></xacro:element>
      <xacro:macro name="one"><x/></xacro:macro><xacro:call macro="${'o' + 'ne'}"/>""",
    "python_expressions": """
      <xacro:property name="xs" value="${[float(x) for x in '1 2 3'.split()]}"/>
      <link name="l" s="${python.sum(xs)}" m="${max(xs)}" l="${len(xs)}" r="${list(python.reversed(xs))}"
            z="${dict(python.zip(['a','b'], [1,2]))}" c="${sorted([3,1,2], key=lambda v: -v)}" e="${list(python.enumerate('ab'))}"
            k="${' '.join(str(v) for v in xs)}" a="${python.abs(-2)} ${python.any([0, 1])} ${python.all([])}"
            i="${xs[1:]} ${xs[-1]} ${'abc'[::-1]}" t="${xacro.tokenize('a,b;c d')}" u="${'A b'.lower().upper()}"
            d="${dict(k=1)['k']}" n="${None is None} ${1 if xs else 2} ${not xs}"/>""",
    "yaml_dotify_units": """
      <xacro:property name="y" value="${xacro.load_yaml('data.yaml')}"/>
      <link name="${y.name}" deg="${y.angles.right}" rad="${y.angles.half}" mm="${y.len}" lst="${y.parts[1].v}"
            same="${y.again.v == y.parts[0].v}" d="${xacro.dotify(dict(a=1)).a}" k="${y.keys()}"/>""",
    "substitution_args": """
      <xacro:arg name="who" default="robot"/><xacro:arg name="k" default="2.5"/>
      <link name="$(arg who)" e="$(eval 2 * k)" s="$(eval who + '_x')" b="$(eval k > 2)" p="$(eval pi)"/>""",
    "namespaced_include_and_eval_comments": """
      <xacro:include filename="inc.xacro" ns="lib"/>
      <xacro:lib.part n="4"/>
      <link name="v" c="${lib.const}"/>
      <!-- xacro:eval-comments --><!-- the constant is ${lib.const} -->""",
}
_FEATURE_FILES = {
    "data.yaml": "name: from_yaml\nangles: {right: !degrees 90, half: !radians pi/2}\nlen: !millimeters 25\n"
                 "parts: [&first {v: 1}, {v: 2}]\nagain: *first\nfmt: '{0:04d}{w}'\n",
    "inc.xacro": f'<robot {XACRO_NS}><xacro:property name="const" value="42"/>'
                 '<xacro:macro name="part" params="n"><link name="part${n}" c="${const}"/></xacro:macro></robot>',
}


@pytest.mark.parametrize("case", list(FEATURES))
def test_xacro_features_expand_as_the_xacro_package_does(case: str, tmp_path: Path) -> None:
    _need_xacro()
    for name, text in _FEATURE_FILES.items():
        (tmp_path / name).write_text(text)
    model = tmp_path / f"{case}.urdf.xacro"
    model.write_text(f'<robot name="features" {XACRO_NS}>{textwrap.dedent(FEATURES[case])}\n</robot>\n')
    ours = read_urdf_text(str(model))
    reference = _reference(model, {})
    diff = _difference(ET.fromstring(ours.encode()), ET.fromstring(reference.encode()))
    assert diff is None, diff


# ----------------------------------------------------------------------------- hostile models
def _write(tmp_path: Path, body: str, name: str = "evil.urdf.xacro") -> Path:
    folder = tmp_path / "model"
    folder.mkdir(exist_ok=True)
    path = folder / name
    path.write_text(f'<robot name="r" {XACRO_NS}>\n{textwrap.dedent(body)}\n<link name="base"/>\n</robot>\n')
    return path


# The way out of xacro's sandbox: a function's globals through python.vars/python.type, then os.system.
_GLOBALS = "python.vars(python.type(xacro.load_yaml))['__globals__']"
_GET = f"python.vars(python.type({_GLOBALS}))['__get__']({_GLOBALS}, xacro.load_yaml)"

ESCAPES = {
    "globals_then_os_system": (f"""<link name="${{{_GET}['os'].system('touch MARKER')}}"/>""",
                               "python.type() is not available"),
    "yaml_unit_tag_runs_the_same_eval": ("""<link name="${xacro.load_yaml('evil.yaml')['x']}"/>""",
                                         "python.type() is not available"),
    "dunder_subclasses": ("""<link name="${''.__class__.__base__.__subclasses__()}"/>""",
                          "attribute '__class__' is not allowed"),
    "dunder_import": ("""<link name="${__import__('os').system('touch MARKER')}"/>""",
                      "name '__import__' is not allowed"),
    "format_reaches_attributes": ("""<link name="${xacro.load_yaml('fmt.yaml').fmt.format(xacro.load_yaml)}"/>""",
                                  "format field '{0.__globals__}' is not allowed"),
    "property_holding_a_function": ("""<xacro:property name="f" value="${xacro.load_yaml}"/>
                                       <link name="${f.__globals__}"/>""", "attribute '__globals__' is not allowed"),
}


@pytest.mark.parametrize("case", list(ESCAPES))
def test_a_xacro_model_never_runs_code(case: str, tmp_path: Path) -> None:
    body, why = ESCAPES[case]
    marker = tmp_path / "model" / "MARKER"
    path = _write(tmp_path, body.replace("MARKER", str(marker)))
    (tmp_path / "model" / "evil.yaml").write_text(
        f"x: !radians {_GET}['os'].system('touch {marker}') + 1\n")
    (tmp_path / "model" / "fmt.yaml").write_text("fmt: '{0.__globals__}'\n")
    proc = zentf(["urdf", "check", str(path)], None)
    line = assert_one_line_error(proc, str(path), why, code=2)
    assert not marker.exists(), "the model ran a command"
    assert "Traceback" not in line


def test_the_escape_does_run_commands_in_the_xacro_package(tmp_path: Path) -> None:
    """The reference is vulnerable: the same model makes xacro itself run the command (so the test above
    would catch a fall back to it)."""
    _need_xacro()
    marker = tmp_path / "model" / "MARKER"
    path = _write(tmp_path, ESCAPES["globals_then_os_system"][0].replace("MARKER", str(marker)))
    subprocess.run([sys.executable, REFERENCE, str(path)], capture_output=True, timeout=60)
    assert marker.exists()


def test_robot_state_publisher_and_launch_refuse_the_escape_before_starting(spawn, tmp_path: Path) -> None:
    marker = tmp_path / "model" / "MARKER"
    path = _write(tmp_path, ESCAPES["globals_then_os_system"][0].replace("MARKER", str(marker)))
    rsp = spawn.python("-m", "nodes.robot_state_publisher", str(path))
    assert rsp.wait(60) == 2
    assert "python.type() is not available" in rsp.output() and "Traceback" not in rsp.output()
    launch = spawn([sys.executable, "-m", "zentf.launch", "urdf", "--no-color", f"model:={path}"])
    launch.wait_for_line(r"robot_state_publisher: error: .*python\.type\(\) is not available", timeout=60)
    assert launch.wait(30) == 2, launch.output()
    assert not marker.exists()


def test_a_xacro_model_reads_only_its_folder_and_the_package_paths(tmp_path: Path) -> None:
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret.yaml").write_text("token: hunter2\n")
    (outside / "secret.xacro").write_text(f'<robot {XACRO_NS}><link name="leaked"/></robot>')
    reads = {
        "absolute_yaml": ("<link name=\"${xacro.load_yaml('/etc/hostname')}\"/>", "'/etc/hostname' is outside"),
        "relative_yaml": ("<link name=\"${xacro.load_yaml('../outside/secret.yaml').token}\"/>", "is outside"),
        "include": (f'<xacro:include filename="{outside}/secret.xacro"/>', "is outside"),
        "include_glob": (f'<xacro:include filename="{outside}/*.xacro"/>', "is outside"),
        "symlink_in_folder": ("<link name=\"${xacro.load_yaml('link.yaml').token}\"/>", "is outside"),
        "find_an_ancestor_by_its_name": (f"<link name=\"${{xacro.load_yaml('$(find {tmp_path.name})/outside/"
                                         "secret.yaml').token}\"/>", "package not found"),
    }
    for case, (body, why) in reads.items():
        path = _write(tmp_path, body, f"{case}.urdf.xacro")
        if case == "symlink_in_folder":
            (path.parent / "link.yaml").symlink_to(outside / "secret.yaml")
        proc = zentf(["urdf", "check", str(path)], None)
        assert_one_line_error(proc, str(path), why, code=2)
        assert "hunter2" not in proc.stdout + proc.stderr and "leaked" not in proc.stdout
    # given as a package path, the same folder is readable
    path = _write(tmp_path, "<link name=\"${xacro.load_yaml('$(find outside)/secret.yaml').token}\"/>"
                            "<joint name=\"j\" type=\"fixed\"><parent link=\"base\"/><child link=\"hunter2\"/></joint>")
    proc = zentf(["urdf", "check", str(path), "--package-path", str(tmp_path)], None)
    assert proc.returncode == 0, proc.stderr
    assert "child(1):  hunter2" in proc.stdout


def test_a_xacro_model_sees_only_the_environment_variables_given(tmp_path: Path) -> None:
    path = _write(tmp_path, '<link name="$(optenv ZENTF_TEST_SECRET none)"/><joint name="j" type="fixed">'
                            '<parent link="base"/><child link="$(optenv ZENTF_TEST_SECRET none)"/></joint>')
    env = {**os.environ, "ZENTF_TEST_SECRET": "hunter2"}
    proc = zentf(["urdf", "check", str(path)], env)
    assert proc.returncode == 0 and "child(1):  none" in proc.stdout and "hunter2" not in proc.stdout
    proc = zentf(["urdf", "check", str(path), "--xacro-env", "ZENTF_TEST_SECRET"], env)
    assert proc.returncode == 0 and "child(1):  hunter2" in proc.stdout
    path = _write(tmp_path, '<link name="$(env ZENTF_TEST_SECRET)"/>', "env.urdf.xacro")
    assert_one_line_error(zentf(["urdf", "check", str(path)], env), "ZENTF_TEST_SECRET is not set or not passed",
                          code=2)


def _macro_bomb(levels: int = 40) -> str:
    body = '<xacro:macro name="m0"><link name="l"/></xacro:macro>\n'
    for i in range(1, levels + 1):
        body += f'<xacro:macro name="m{i}"><xacro:m{i - 1}/><xacro:m{i - 1}/></xacro:macro>\n'
    return body + f"<xacro:m{levels}/>"


def test_the_macro_bomb_stops_with_one_line_within_the_default_budget(tmp_path: Path) -> None:
    path = _write(tmp_path, _macro_bomb())
    assert path.stat().st_size < 3000
    t0 = time.monotonic()
    proc = zentf(["urdf", "check", str(path)], None, timeout=120)
    assert_one_line_error(proc, "xacro expansion stopped", "elements", "--xacro-budget", code=2)
    assert time.monotonic() - t0 < 60
    # a given budget is the limit, not none: twice the memory (a 1,048,576-element cap the bomb does not reach
    # in 2 s), and the 2 s of CPU it was given stop it
    proc = zentf(["urdf", "check", str(path), "--xacro-budget", "2s,1GB"], None, timeout=120)
    assert_one_line_error(proc, "xacro expansion stopped", "CPU budget of 2 s", code=2)


BOMBS = {
    "long_string": ("<link name=\"${'x' * 10**10}\"/>", "a repeated sequence of 10000000000 items"),
    "huge_integer": ('<link name="${10**10**10}"/>', "a power over"),
    "endless_comprehension": ('<link name="${[i for i in python.range(10**15)]}"/>', "over the budget's"),
    "busy_comprehension": ('<link name="${python.sum(1 for i in python.range(3000) for j in python.range(3000))}"/>',
                           "CPU budget of 1 s"),
    "format_width": ("<link name=\"${xacro.load_yaml('fmt.yaml').wide.format(1)}\"/>",
                     "format width or precision 999999999"),
    "recursive_macro": ('<xacro:macro name="r"><xacro:r/></xacro:macro><xacro:r/>',
                        "macro calls nested deeper than 200"),
    "self_include": ('<xacro:include filename="self_include.urdf.xacro"/>', "includes nested deeper than 64"),
    "lambda_recursion": ('<link name="${(lambda f: f(f))(lambda f: f(f))}"/>', "nested deeper than"),
    "circular_properties": ('<xacro:property name="a" value="${b}"/><xacro:property name="b" value="${a}"/>'
                            '<link name="${a}"/>', "circular property definition"),
    "yaml_alias_bomb": ("<link name=\"${xacro.load_yaml('laughs.yaml')}\"/>", "YAML aliases unfold to more than"),
    "yaml_recursive_alias": ("<link name=\"${xacro.load_yaml('loop.yaml')}\"/>", "a YAML alias refers to itself"),
    "factorial": ('<link name="${math.factorial(10**7)}"/>', "math.factorial of 10000000 is refused"),
    "many_big_strings": ("<xacro:property name=\"s\" value=\"${'x' * 8000000}\"/>"
                         '<link name="${python.len([s + str(i) for i in python.range(1000)])}"/>',
                         "out of its memory budget"),
}


@pytest.mark.parametrize("case", list(BOMBS))
def test_hostile_expressions_and_structures_stop_with_one_line(case: str, tmp_path: Path) -> None:
    body, why = BOMBS[case]
    path = _write(tmp_path, body, f"{case}.urdf.xacro")
    laughs = "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{c}: &{c} [{', '.join(['*' + p] * 10)}]\n" for p, c in zip("abcdefgh", "bcdefghi"))
    (path.parent / "laughs.yaml").write_text(laughs)
    (path.parent / "loop.yaml").write_text("a: &a [1, *a]\n")
    (path.parent / "fmt.yaml").write_text("wide: '{:>999999999}'\n")
    proc = zentf(["urdf", "check", str(path), "--xacro-budget", "1s"], None, timeout=120)
    assert_one_line_error(proc, why, code=2)


def test_xml_entity_bombs_are_refused(tmp_path: Path) -> None:
    lol = '<!DOCTYPE robot [<!ENTITY a "aaaaaaaaaa">' + "".join(
        f'<!ENTITY {c} "{("&" + p + ";") * 10}">' for p, c in zip("abcdefgh", "bcdefghi")) + "]>"
    for suffix in (".urdf.xacro", ".urdf"):
        path = tmp_path / f"lol{suffix}"
        path.write_text(f'{lol}<robot name="&i;" {XACRO_NS}><link name="a"/></robot>')
        assert_one_line_error(zentf(["urdf", "check", str(path)], None), "entity declarations are not allowed",
                              code=2)


def test_the_budget_option_is_checked_and_named_alike_everywhere(tmp_path: Path, zenoh_env) -> None:
    path = _write(tmp_path, "")
    assert_one_line_error(zentf(["urdf", "check", str(path), "--xacro-budget", "lots"], None),
                          "--xacro-budget expects", code=2)
    assert zentf(["urdf", "check", str(path), "--xacro-budget", "60s,2GB"], None).returncode == 0
    for program in ("robot-state-publisher", "joint-state-publisher"):
        proc = zentf([program, str(path), "--xacro-budget", "0s"], zenoh_env)
        assert_one_line_error(proc, "--xacro-budget: CPU seconds must be", code=2)
    launch = subprocess.run([sys.executable, "-m", "zentf.launch", "urdf", "--show-args"], capture_output=True,
                            text=True, cwd=str(REPO), timeout=60)
    assert "xacro_budget" in launch.stdout, launch.stdout


def test_the_expanding_process_is_confined_by_the_kernel(tmp_path: Path) -> None:
    """Below the evaluator: after ``confine`` the process cannot read outside its roots, write, execute or
    connect, even by calling Python's os functions directly."""
    from zentf.urdf.xacro.sandbox import landlock_abi

    if landlock_abi() < 1:
        if os.environ.get("CI"):
            pytest.fail("the kernel has no Landlock")
        pytest.skip("the kernel has no Landlock (Linux >= 5.13 with landlock in the LSM list)")
    allowed = tmp_path / "allowed"
    allowed.mkdir()
    (allowed / "ok.txt").write_text("fine")
    (tmp_path / "secret.txt").write_text("hunter2")
    probe = textwrap.dedent(f"""
        import os, socket, sys
        from zentf.urdf.xacro.sandbox import confine
        print("applied", confine([{str(allowed)!r}], 5.0, 256 << 20)["landlock"])
        print("read allowed", open({str(allowed / 'ok.txt')!r}).read())
        for what, act in [("read outside", lambda: open({str(tmp_path / 'secret.txt')!r}).read()),
                          ("write inside", lambda: open({str(allowed / 'new.txt')!r}, "w")),
                          ("connect", lambda: socket.create_connection(("127.0.0.1", 9), 1)),
                          ("exec", lambda: os.execv("/bin/echo", ["echo", "EXECUTED"]))]:
            try:
                act()
                print(what, "ALLOWED")
            except OSError as e:
                print(what, "denied", type(e).__name__)
        """)
    proc = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, timeout=60,
                          env={**os.environ, "PYTHONPATH": str(REPO)})
    out = proc.stdout
    assert "read allowed fine" in out, (out, proc.stderr)
    for what in ("read outside", "write inside", "connect", "exec"):
        assert f"{what} denied" in out, (out, proc.stderr)
    assert "EXECUTED" not in out and "hunter2" not in out


def test_library_errors_for_xacro_are_one_line_with_the_place(tmp_path: Path) -> None:
    path = _write(tmp_path, '<link name="${undefined_name}"/>')
    with pytest.raises(URDFError) as exc:
        load_urdf(path)
    assert str(exc.value) == (f"{path}:2: xacro: name 'undefined_name' is not defined (when evaluating "
                              f"expression 'undefined_name')")
