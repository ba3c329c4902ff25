"""Property-based tests (hypothesis) of the two readers of user text: any text either loads or
raises a SimbridgeError, never another exception.

- The URDF reader (``simbridge.model.urdf.parse_urdf``, no engine): arbitrary text; text that starts
  like XML; and URDF-like XML built from robots, links, joints, geometry and attributes drawn
  by hypothesis, with hostile values (NaN, infinities, huge and negative numbers, unknown
  names, missing elements, cycles, entities).
- The scenario reader (``simbridge.compare.scenario.loads_scenario``): arbitrary text and
  TOML-like documents built from the scenario's own keys with values of every TOML type.

Settings: a fixed number of examples and no deadline (the shared 2-core machine makes per-example
timing noise), derandomised so that a run is repeatable: a few seconds in all.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from simbridge.compare.scenario import loads_scenario
from simbridge.exceptions import SimbridgeError
from simbridge.model.urdf import UrdfModel, UrdfSource, parse_urdf

SETTINGS = settings(
    max_examples=150,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


@pytest.fixture(autouse=True)
def _quiet() -> Iterator[None]:
    # the lenient reader warns once per odd file: thousands of records otherwise; the level
    # goes back as found, so that later tests see the records they expect
    log = logging.getLogger("simbridge")
    level = log.level
    log.setLevel(logging.ERROR)
    yield
    log.setLevel(level)


def parse(text: str, folder: Path) -> UrdfModel | None:
    """Parse URDF text as load_urdf does (meshes resolved against ``folder``); None when the
    reader refused it with a SimbridgeError. Any other exception fails the test."""
    try:
        return parse_urdf(UrdfSource(text, None, folder, "<urdf text>"))
    except SimbridgeError:
        return None


def check_model(model: UrdfModel | None) -> None:
    """A model that loaded is a tree in PyBullet's order: joint i's child is link i + 1."""
    if model is None:
        return
    names = [link.name for link in model.links]
    assert len(set(names)) == len(names)
    assert [j.child for j in model.joints] == names[1:]
    for joint in model.joints:
        assert joint.parent in names and joint.child in names


# ---------------------------------------------------------------- the URDF reader


@SETTINGS
@given(st.text(max_size=400))
def test_any_text_is_a_urdf_or_a_urdf_error(tmp_path_factory, text):
    check_model(parse(text, tmp_path_factory.getbasetemp()))


@SETTINGS
@given(
    st.text(
        alphabet=st.sampled_from(list("<>/=\"' &;![]?-robtlinkjeamsxyz0123456789.\n\t\x00é")),
        max_size=300,
    )
)
def test_markup_soup_is_a_urdf_or_a_urdf_error(tmp_path_factory, text):
    check_model(parse("<robot " + text, tmp_path_factory.getbasetemp()))


SANE = st.sampled_from(["0", "0.1", "1", "0.05", "-0.2", "2"])
HOSTILE = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(
        [
            "nan",
            "-inf",
            "1e400",
            "1e-400",
            "-0",
            "0x10",
            "1,5",
            "",
            " ",
            "abc",
            "1e308",
            "-1e308",
            "3 4",
            "1e",
            ".",
            "+.5e-3",
        ]
    ),  # fmt: skip
    st.integers(-(10**30), 10**30).map(str),
)
NUMBERS = st.one_of(SANE, SANE, SANE, HOSTILE)  # mostly sane: the reader goes deep
ODD_NAMES = st.one_of(
    st.sampled_from(["", " ", "&amp;", "a b", "é", "&#9;"]),
    st.text(alphabet=st.characters(blacklist_categories=["Cs", "Cc"]), max_size=12),
    st.text(max_size=4),  # control characters too: not XML, a parse error
)
NAMES = st.one_of(st.sampled_from(["a", "b", "c", "d", "base"]), ODD_NAMES)


def _attr(value: str) -> str:
    return (
        value.replace("&", "&amp;")
        .replace("<", "&lt;")
        .replace('"', "&quot;")
        .replace("\x00", "")
        .replace("\r", "&#13;")
    )


def often(draw, n: int = 3) -> bool:
    """True n times in n + 1 (and when hypothesis simplifies)."""
    return bool(draw(st.sampled_from([True] * n + [False])))


@st.composite
def vectors(draw, n: int = 3) -> str:
    return " ".join(draw(st.lists(NUMBERS, min_size=0, max_size=n + 1)))


@st.composite
def geometries(draw) -> str:
    kind = draw(st.sampled_from(["box", "sphere", "cylinder", "capsule", "mesh", "plane", "none",
                                 "torus"]))  # fmt: skip
    if kind == "box":
        shape = f'<box size="{_attr(draw(vectors()))}"/>'
    elif kind in ("sphere", "cylinder", "capsule"):
        shape = f'<{kind} radius="{_attr(draw(NUMBERS))}" length="{_attr(draw(NUMBERS))}"/>'
    elif kind == "mesh":
        name = draw(st.sampled_from(["missing.stl", "x.ply", "", "package://p/m.obj"]))
        shape = f'<mesh filename="{name}" scale="{_attr(draw(vectors()))}"/>'
    elif kind == "plane":
        shape = f'<plane normal="{_attr(draw(vectors()))}"/>'
    elif kind == "none":
        shape = ""
    else:
        shape = "<torus/>"
    origin = f'<origin xyz="{_attr(draw(vectors()))}" rpy="{_attr(draw(vectors()))}"/>'
    return f"<geometry>{shape}</geometry>" + (origin if draw(st.booleans()) else "")


@st.composite
def links(draw, name: str) -> str:
    parts = []
    if draw(st.booleans()):
        six = ["ixx", "ixy", "ixz", "iyy", "iyz", "izz"]
        keys = six if often(draw) else draw(st.lists(st.sampled_from(six), unique=True))
        inertia = " ".join(f'{k}="{_attr(draw(NUMBERS))}"' for k in keys)
        mass = f'<mass value="{_attr(draw(NUMBERS))}"/>' if often(draw, 5) else ""
        parts.append(f"<inertial>{mass}<inertia {inertia}/></inertial>")
    for tag in draw(st.lists(st.sampled_from(["visual", "collision"]), max_size=3)):
        parts.append(f"<{tag}>{draw(geometries())}</{tag}>")
    if draw(st.booleans()):
        parts.append(f'<contact><lateral_friction value="{_attr(draw(NUMBERS))}"/></contact>')
    return f'<link name="{_attr(name)}">' + "".join(parts) + "</link>"


@st.composite
def joints(draw, link_names: list[str]) -> str:
    name = draw(NAMES)
    jtype = draw(st.sampled_from(["revolute", "continuous", "prismatic", "fixed"] * 3
                                 + ["floating", "planar", "spherical", "hinge", ""]))  # fmt: skip
    pool = st.sampled_from(link_names) if link_names else NAMES
    k = draw(st.integers(1, max(len(link_names) - 1, 1)))
    if len(link_names) > 1 and often(draw):  # mostly a tree: parent before child
        parent, child = draw(st.sampled_from(link_names[:k])), link_names[k]
    else:
        parent, child = draw(st.one_of(pool, NAMES)), draw(st.one_of(pool, NAMES))
    parts = [f'<parent link="{_attr(parent)}"/>', f'<child link="{_attr(child)}"/>']
    if not often(draw, 5):  # now and then one or both missing
        parts = draw(st.permutations(parts))[: draw(st.integers(0, 1))]
    if draw(st.booleans()):
        parts.append(f'<axis xyz="{_attr(draw(vectors()))}"/>')
    if often(draw):
        attrs = " ".join(
            f'{k}="{_attr(draw(NUMBERS))}"'
            for k in draw(
                st.lists(st.sampled_from(["lower", "upper", "effort", "velocity"]), unique=True)
            )  # fmt: skip
        )
        parts.append(f"<limit {attrs}/>")
    if draw(st.booleans()):
        parts.append(f'<dynamics damping="{_attr(draw(NUMBERS))}"/>')
    if draw(st.booleans()):
        parts.append(f'<origin xyz="{_attr(draw(vectors()))}"/>')
    return f'<joint name="{_attr(name)}" type="{jtype}">' + "".join(parts) + "</joint>"


@st.composite
def robots(draw) -> str:
    names = draw(st.lists(NAMES, min_size=1, max_size=5, unique=True))
    body = [draw(links(n)) for n in names]
    body += [draw(joints(names)) for _ in range(draw(st.integers(0, len(names) + 1)))]
    body = draw(st.permutations(body))
    name = draw(NAMES) if often(draw, 9) else None
    head = "" if name is None else f' name="{_attr(name)}"'
    prolog = draw(st.sampled_from(["", '<?xml version="1.0"?>\n', "", "\n\n",
                                   '<!DOCTYPE robot [<!ENTITY e "x">]>']))  # fmt: skip
    return f"{prolog}<robot{head}>" + "\n".join(body) + "</robot>"


@SETTINGS
@given(robots())
def test_urdf_like_xml_is_a_model_or_a_urdf_error(tmp_path_factory, text):
    check_model(parse(text, tmp_path_factory.getbasetemp()))


@SETTINGS
@given(robots(), st.integers(0, 10_000), st.sampled_from(["", "<", ">", "&", '"', "\x00", "\r"]))
def test_damaged_urdf_xml_is_a_model_or_a_urdf_error(tmp_path_factory, text, at, junk):
    """A drawn robot with one character inserted or the text cut."""
    at %= len(text) + 1
    for damaged in (text[:at] + junk + text[at:], text[:at]):
        check_model(parse(damaged, tmp_path_factory.getbasetemp()))


def test_the_generator_makes_loadable_robots_too(tmp_path):
    """The strategies are not only noise: a fixed well-formed draw parses into a model."""
    text = (
        '<robot name="r"><link name="a"><collision><geometry><box size="1 1 1"/></geometry>'
        '</collision></link><link name="b"/><joint name="j" type="continuous">'
        '<parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint></robot>'
    )
    model = parse(text, tmp_path)
    assert model is not None and [j.name for j in model.joints] == ["j"]


# ---------------------------------------------------------------- the scenario reader


def load(text: str) -> object | None:
    try:
        return loads_scenario(text, file="<property>")
    except SimbridgeError:
        return None


@SETTINGS
@given(st.text(max_size=400))
def test_any_text_is_a_scenario_or_a_scenario_error(text):
    load(text)


TOML_VALUES = st.recursive(
    st.one_of(
        st.booleans(),
        st.integers(-(10**20), 10**20),
        st.floats(allow_nan=True, allow_infinity=True),
        st.text(max_size=8),
        st.sampled_from(
            [
                "1/240",
                "1/0",
                "-1/240",
                "r2d2.urdf",
                "pendulum.urdf",
                "velocity",
                "position",
                "torque",
                "hinge",
                "pybullet",
                "urdf",
                "math:sqrt",
            ]
        ),
    ),  # fmt: skip
    lambda inner: st.one_of(
        st.lists(inner, max_size=4), st.dictionaries(st.sampled_from(["a", "hinge"]), inner)
    ),
    max_leaves=8,
)
BASE: dict[str, object] = {
    "name": "p",
    "timestep": "1/240",
    "robots": [{"name": "pendulum", "urdf": "pendulum.urdf", "fixed_base": True,
                "position": [0.0, 0.0, 1.0], "joint_positions": {"hinge": 0.5}}],
    "phases": [{"name": "swing", "steps": 10, "commands": [
        {"joints": "hinge", "mode": "velocity", "target": 0.0, "max_force": 0.0}]}],
}  # fmt: skip
KEYS = ["name", "description", "profile", "timestep", "gravity", "subject", "headline", "urdf",
        "position", "orientation", "rpy", "fixed_base", "joint_positions", "steps", "joints",
        "mode", "target", "max_force", "kp", "kd", "robot", "robots", "phases", "commands",
        "outcomes", "controller", "unknown_key"]  # fmt: skip


def _toml(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if value != value:
            return "nan"
        if value in (float("inf"), float("-inf")):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        escaped = value.replace("\\", "\\\\").replace('"', '\\"')
        escaped = "".join(c if c.isprintable() else f"\\u{ord(c):04x}" for c in escaped)
        return f'"{escaped}"'
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    assert isinstance(value, dict)
    return "{" + ", ".join(f"{_toml(str(k))} = {_toml(v)}" for k, v in value.items()) + "}"


def _dumps(doc: dict[str, object]) -> str:
    """A document as TOML with inline tables (any structure the mutations leave)."""
    return "".join(f"{_toml(str(k))} = {_toml(v)}\n" for k, v in doc.items())


@st.composite
def scenarios(draw) -> str:
    """The valid BASE scenario with 1 or 2 mutations: a key set to a drawn TOML value at any
    depth, deleted, or added."""
    import copy

    doc = copy.deepcopy(BASE)
    for _ in range(draw(st.integers(1, 2))):
        node: object = doc
        while True:  # walk down a random path
            if isinstance(node, dict) and node and often(draw, 2):
                child = node[draw(st.sampled_from(sorted(node)))]
            elif isinstance(node, list) and node and often(draw, 2):
                child = node[draw(st.integers(0, len(node) - 1))]
            else:
                break
            if not isinstance(child, (dict, list)):
                break
            node = child
        action = draw(st.sampled_from(["set", "set", "delete", "add"]))
        if isinstance(node, dict):
            key = draw(st.sampled_from(sorted(node) or KEYS))
            if action == "delete":
                node.pop(key, None)
            else:
                node[draw(st.sampled_from(KEYS)) if action == "add" else key] = draw(TOML_VALUES)
        elif isinstance(node, list):
            if action == "delete" and node:
                node.pop(draw(st.integers(0, len(node) - 1)))
            else:
                node.append(draw(TOML_VALUES))
    return _dumps(doc)


@SETTINGS
@given(scenarios())
def test_scenario_like_toml_is_a_scenario_or_a_scenario_error(text):
    load(text)


def test_a_valid_scenario_loads():
    """The readers' happy path: a plain scenario with the keys the strategies draw from."""
    text = (
        'name = "p"\ntimestep = "1/240"\n[[robots]]\nname = "pendulum"\nurdf = "pendulum.urdf"\n'
        'fixed_base = true\n[[phases]]\nname = "swing"\nsteps = 10\n[[phases.commands]]\n'
        'joints = "hinge"\nmode = "velocity"\ntarget = 0.0\nmax_force = 0.0\n'
    )
    assert load(text) is not None
