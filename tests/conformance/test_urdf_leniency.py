"""Where PyBullet's URDF reader is lenient, simbridge reads the same values and says so in one
warning naming the file, the line and what it assumed; where PyBullet refuses, so does
simbridge, in one line naming the file, the line and the element. Every case is loaded by raw
PyBullet too, as the reference."""

from __future__ import annotations

import logging
import re
import signal
import subprocess
import sys

import _raw
import pytest

from simbridge import exceptions as exc

INERTIAL = (
    '<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>'
    "</inertial>"
)
BOX = '<collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>'


def robot(
    joint: str = '<origin xyz="1 2 3"/>',
    link_b: str = f"{INERTIAL}{BOX}",
    head: str = "",
    tail: str = "",
    jtype: str = "revolute",
    limit: str = '<limit lower="-1" upper="1" effort="1" velocity="1"/>',
    axis: str = '<axis xyz="0 0 1"/>',
) -> str:
    """A two-link robot, one element per line (line 1 the <robot>, line 4 the joint)."""
    return (
        f'{head}<robot name="r">\n'
        f'<link name="a">{INERTIAL}{BOX}</link>\n'
        f'<link name="b">{link_b}</link>\n'
        f'<joint name="j" type="{jtype}"><parent link="a"/><child link="b"/>{joint}{axis}'
        f"{limit}</joint>\n</robot>\n{tail}"
    )


# case -> (URDF text, the line and what the one warning says)
LENIENT = {
    "numbers with units": (
        robot(link_b=f"{INERTIAL.replace('1', '2kg', 1)}{BOX}"),
        r"line 3: link 'b' <mass> value='2kg' read as 2 \(C atof: its leading number\)",
    ),
    "comma-separated numbers": (
        robot('<origin xyz="0.07, 0, -0.69"/>'),
        r"line 4: joint 'j' <origin xyz> '0\.07, 0, -0\.69' read as \(0\.07, 0, -0\.69\)",
    ),
    "text where numbers belong": (
        robot('<origin xyz="$(optenv X 0.19 0 0.149)"/>'),
        r"line 4: joint 'j' <origin xyz> '\$\(optenv X 0\.19 0 0\.149\)' read as \(0, 0, 0\.19\)"
        r".*the first 3 of 5 numbers used",
    ),
    "a tab is no separator": (
        robot('<origin xyz="1\t2 3 4"/>'),
        r"line 4: joint 'j' <origin xyz> '1\\t2 3 4' read as \(1, 3, 4\)",
    ),
    "a line break is no separator": (
        robot('<origin xyz="1 2\n3 4"/>'),
        r"line 4: joint 'j' <origin xyz> '1 2\\n3 4' read as \(1, 2, 4\)",
    ),
    "four numbers in an rpy": (
        robot('<origin xyz="1 2 3" rpy="0.1 0.2 0.3 0.4"/>'),
        r"line 4: joint 'j' <origin rpy> '0\.1 0\.2 0\.3 0\.4' read as \(0\.1, 0\.2, 0\.3\): the "
        r"first 3 of 4 numbers used",
    ),
    "two numbers in an xyz": (
        robot('<origin xyz="1 2" rpy="0.1 0.2 0.3"/>'),
        r"line 4: joint 'j' <origin xyz> '1 2': fewer than 3 numbers .* read as \(0, 0, 0\)",
    ),
    "hexadecimal and exponents": (
        robot('<origin xyz="0x10 1e1 .5e"/>'),
        r"line 4: joint 'j' <origin xyz> '0x10 1e1 \.5e' read as \(16, 10, 0\.5\)",
    ),
    "a limit with a unit": (
        robot(limit='<limit lower="-1rad" upper="1" effort="1" velocity="1"/>'),
        r"line 4: joint 'j' <limit> lower='-1rad' read as -1",
    ),
    "a box with two sizes": (
        robot(
            link_b=f'{INERTIAL}<collision><geometry><box size="0.1 0.2"/></geometry></collision>'
        ),
        r"line 3: link 'b' <collision> #0 <box size> '0\.1 0\.2': fewer than 3 numbers",
    ),
    "one mesh scale": (
        robot(
            link_b=f'{INERTIAL}<collision><geometry><mesh filename="{_raw.DATA}/cube.obj" '
            'scale="2"/></geometry></collision>'
        ),
        r"line 3: link 'b' <collision> #0 <mesh scale> '2' read as \(2, 2, 2\)",
    ),
    "blank lines before the declaration": (
        robot(head='\n\n<?xml version="1.0"?>\n'),
        r"line 3: the XML declaration after blank lines at the start of the file",
    ),
    "a NUL byte ends a line": (
        robot(tail="\0"),
        r"line 6: a NUL byte at the end of a line, ignored",
    ),
    "a NUL byte in a name": (
        robot().replace('name="j"', 'name="j\0k"'),
        r"line 4: a NUL byte, read as a line break",
    ),
    "an element after the robot": (
        robot(tail="<other/>\n"),
        r"line 6: <other> element after the <robot> element ignored",
    ),
    "text before the robot": (
        robot(head="junk\n"),
        r"line 1: text before the <robot> element ignored",
    ),
    "an & that starts no entity": (
        robot(link_b=f"{INERTIAL}{BOX}<!-- & -->").replace('name="r"', 'name="r&d"'),
        r"line 1: an '&' that starts no XML entity read as the character '&'",
    ),
    "a Latin-1 byte in a comment": (
        robot(head="<!-- caf\xe9 -->").encode("latin-1"),
        r"line 1: byte 0xe9 is not UTF-8: read as U\+FFFD",
    ),
    "products of inertia given in part": (
        robot(link_b=INERTIAL.replace(' iyz="0"', "") + BOX),
        r"line 3: link 'b' <inertia>: ixy, ixz ignored",
    ),
}


@pytest.mark.parametrize("case", sorted(LENIENT))
def test_lenient_input_reads_as_pybullet_reads_it(make_sim, case, caplog, tmp_path):
    text, warning = LENIENT[case]
    path = tmp_path / "lenient.urdf"
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    raw = _raw.raw_load(str(path))
    caplog.set_level(logging.WARNING, logger="simbridge")
    sim = make_sim()
    body = sim.load_urdf(path)
    assert _raw.table_difference(sim.joints(body), raw.table) is None
    assert _raw.dynamics_difference(sim, body, raw.dynamics, 1e-7) is None
    assert (
        _raw.frames_difference(_raw.sim_frames(sim, body), raw.frames, _raw.frame_rel(sim.backend))
        is None
    )
    records = [r for r in caplog.records if r.name == "simbridge.model.urdf"]
    assert len(records) == 1, [r.getMessage() for r in records]
    assert records[0].getMessage().startswith(f"{path}: read as PyBullet reads it: ")
    assert re.search(warning, records[0].getMessage()), records[0].getMessage()


# case -> (URDF text, simbridge's error and message); raw PyBullet refuses every one
REFUSED = {
    "a comment before the declaration": (
        robot(head='<!-- c -->\n<?xml version="1.0"?>\n'),
        exc.UrdfParseError,
        r"<urdf text>: malformed URDF XML: XML or text declaration not at start of entity: "
        r"line 2, column 0",
    ),
    "text after the robot": (
        robot(tail="junk"),
        exc.UrdfParseError,
        r"<urdf text>: malformed URDF XML: text after the last element: line 6",
    ),
    "a NUL byte before the end of a tag": (
        robot().replace("<axis", "\0<<axis"),
        exc.UrdfParseError,
        r"<urdf text>: malformed URDF XML: not well-formed \(invalid token\): line 4, column 1 "
        r"\(inside <joint> 'j' of line 4\)",
    ),
    "a duplicate attribute": (
        robot('<origin xyz="1 2 3" xyz="4 5 6"/>'),
        exc.UrdfParseError,
        r"duplicate attribute: line 4, column \d+ \(inside <joint> 'j' of line 4\)",
    ),
    "a mismatched tag": (
        robot().replace("</joint>", "</link>"),
        exc.UrdfParseError,
        r"mismatched tag: line 4, column \d+ \(inside <joint> 'j' of line 4\)",
    ),
    "an axis of two numbers": (
        robot(axis='<axis xyz="0 1"/>'),
        exc.UrdfStructureError,
        r"<urdf text>:4: joint 'j' <axis>: expected 3 numbers, got '0 1' \(PyBullet refuses it",
    ),
    "a mass without value": (
        robot(link_b=INERTIAL.replace(' value="1"', "") + BOX),
        exc.UrdfStructureError,
        r"<urdf text>:3: link 'b' <mass>: has no value attribute \(PyBullet refuses it too\)",
    ),
    "an inertial without mass": (
        robot(link_b=INERTIAL.replace('<mass value="1"/>', "") + BOX),
        exc.UrdfStructureError,
        r"<urdf text>:3: link 'b' <inertial>: has no <mass>",
    ),
    "an inertial without inertia": (
        robot(link_b='<inertial><mass value="1"/></inertial>'),
        exc.UrdfStructureError,
        r"<urdf text>:3: link 'b' <inertial>: has no <inertia>",
    ),
    "an inertia without izz": (
        robot(link_b=INERTIAL.replace(' izz="0.1"', "") + BOX),
        exc.UrdfStructureError,
        r"<urdf text>:3: link 'b' <inertia>: needs at least ixx, iyy and izz",
    ),
    "a sphere without radius": (
        robot(link_b=f"{INERTIAL}<collision><geometry><sphere/></geometry></collision>"),
        exc.UrdfStructureError,
        r"<urdf text>:3: link 'b' <collision> #0 <sphere>: has no radius attribute",
    ),
    "a cylinder without length": (
        robot(link_b=f'{INERTIAL}<visual><geometry><cylinder radius="1"/></geometry></visual>'),
        exc.UrdfStructureError,
        r"<urdf text>:3: link 'b' <visual> #0 <cylinder>: has no length attribute",
    ),
    "an empty dynamics": (
        robot("<dynamics/>"),
        exc.UrdfStructureError,
        r"<urdf text>:4: joint 'j' <dynamics>: has neither damping nor friction",
    ),
    "a nameless material": (
        robot(
            link_b=f"{INERTIAL}<visual><geometry><box size='1 1 1'/></geometry><material>"
            "<color rgba='1 0 0 1'/></material></visual>"
        ),
        exc.UrdfStructureError,
        r"<urdf text>:3: link 'b' <visual> #0 <material>: has no name attribute",
    ),
    "a contact value missing": (
        robot(link_b=f"{INERTIAL}<contact><lateral_friction/></contact>"),
        exc.UrdfStructureError,
        r"<urdf text>:3: link 'b' <contact><lateral_friction>: has no value attribute",
    ),
    "a robot without name": (
        robot().replace(' name="r"', ""),
        exc.UrdfStructureError,
        r"<urdf text>:1: <robot>: has no name attribute",
    ),
    "a geometry without shape": (
        robot(link_b=f"{INERTIAL}<collision><geometry/></collision>"),
        exc.UrdfStructureError,
        r"<urdf text>:3: link 'b' <collision> #0: has no <geometry>",
    ),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_what_pybullet_refuses_is_refused_in_one_line(make_sim, case):
    text, error, message = REFUSED[case]
    p, _ = _raw.raw_client()
    with pytest.raises(p.error):
        _raw.raw_load(text)
    with pytest.raises(error, match=message) as info:
        make_sim().load_urdf(text)
    assert "\n" not in str(info.value)


_RAW_CHILD = """
import os, sys, tempfile
import pybullet as p
p.connect(p.DIRECT)
fd, path = tempfile.mkstemp(suffix=".urdf")
os.write(fd, sys.stdin.read().encode())
os.close(fd)
try:
    p.loadURDF(path)
finally:
    os.unlink(path)
"""

# PyBullet 3.2.7 ends the process on these (SIGSEGV): refused here with the reason
CRASHES = {
    "a joint without type": (
        robot().replace(' type="revolute"', ""),
        r"<urdf text>:4: joint 'j': has no type attribute \(PyBullet refuses it too\)",
    ),
    "several root links": (
        robot(link_b=f"{INERTIAL}</link>\n<link name='c'>{INERTIAL}"),
        r"<urdf text>:1: robot 'r': 2 root links \['a', 'c'\]; a URDF needs exactly one root "
        r"\(PyBullet crashes on several\)",
    ),
}


@pytest.mark.parametrize("case", sorted(CRASHES))
def test_what_crashes_pybullet_is_refused_in_one_line(make_sim, case):
    text, message = CRASHES[case]
    child = subprocess.run(
        [sys.executable, "-c", _RAW_CHILD], input=text, capture_output=True, text=True, timeout=60
    )
    assert child.returncode == -signal.SIGSEGV
    with pytest.raises(exc.UrdfStructureError, match=message) as info:
        make_sim().load_urdf(text)
    assert "\n" not in str(info.value)


def test_a_zero_axis_is_refused_where_pybullet_reads_no_axis(make_sim):
    """``<axis/>`` without xyz leaves PyBullet's joint axis unset (measured: (0, 0, 0) in one
    process, 9e223 in another: memory never written); ``xyz="0 0 0"`` is a joint with no
    direction. Neither is simulated faithfully anywhere: refused, naming the line."""
    text = robot(axis="<axis/>")
    with pytest.raises(
        exc.UrdfStructureError, match=r"<urdf text>:4: joint 'j' <axis>: axis must not be zero"
    ):
        make_sim().load_urdf(text)
    text = robot(axis='<axis xyz="0 0 0"/>')
    with pytest.raises(
        exc.UrdfStructureError, match=r"<urdf text>:4: joint 'j' <axis>: axis must not be zero"
    ):
        make_sim().load_urdf(text)


def test_plane_geometry_is_an_infinite_plane_on_every_backend(make_sim):
    """Bullet's <plane normal>: a box dropped on plane_implicit.urdf rests on it."""
    sim = make_sim()
    sim.load_urdf("plane_implicit.urdf")
    box = sim.load_urdf("cube_small.urdf", base_position=(3.0, -40.0, 0.2))
    sim.step(480)
    z = sim.base_state(box).position[2]
    assert 0.024 < z < 0.026  # cube_small is 5 cm: its centre rests 2.5 cm up


def _ascii_stl(side: float) -> str:
    """A cube of ``side`` metres as an ASCII STL (12 facets)."""
    h = side / 2
    corners = [(x, y, z) for x in (-h, h) for y in (-h, h) for z in (-h, h)]
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1)]
    faces += [(2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    lines = ["solid cube"]
    for face in faces:
        lines += ["facet normal 0 0 0", "outer loop"]
        lines += ["vertex {} {} {}".format(*corners[i]) for i in face]
        lines += ["endloop", "endfacet"]
    return "\n".join(lines + ["endsolid cube", ""])


# case -> (link b's elements, PyBullet's own warning, the one warning every backend gives)
PYBULLET_WARNS = {
    "a link without <inertial>": (
        BOX,
        r"No inertial data for link, using mass=1, .*: b$",
        r"lenient\.urdf:3: link 'b' has no <inertial>: simulated with mass 1 kg",
    ),
    "an ASCII STL": (
        f'{INERTIAL}<collision><geometry><mesh filename="cube.stl"/></geometry></collision>{BOX}',
        r"cannot extract mesh from '.*cube\.stl'",
        r"lenient\.urdf:3: link 'b' <collision> #0 <mesh>: 'cube\.stl' is not a binary STL, "
        r"which PyBullet alone reads: the shape is left out",
    ),
}


@pytest.mark.parametrize("case", sorted(PYBULLET_WARNS))
def test_what_pybullet_warns_of_every_backend_says_once(make_sim, case, caplog, tmp_path):
    """A link without <inertial> (PyBullet: mass 1 at the link frame) and an ASCII STL (PyBullet
    reads binary STL only and leaves the shape out): raw PyBullet warns; every backend loads
    the same body (joint table, masses, inertias, frames) and gives one warning on the
    ``simbridge.model.urdf`` logger naming the file, the line and the link (the PyBullet backend's
    own copy of PyBullet's lines is kept at DEBUG). MuJoCo refused the whole robot over the
    ASCII STL (its compiler's error) and gave the missing <inertial> its mass without a word."""
    link_b, pybullet_says, we_say = PYBULLET_WARNS[case]
    (tmp_path / "cube.stl").write_text(_ascii_stl(0.3))
    path = tmp_path / "lenient.urdf"
    path.write_text(robot(link_b=link_b))
    caplog.set_level(logging.DEBUG, logger="simbridge")
    raw = _raw.raw_load(str(path))
    said = [r.getMessage() for r in caplog.records]  # (the classifier's level: DEBUG)
    assert any(re.search(pybullet_says, m) for m in said), said
    caplog.clear()
    sim = make_sim()
    body = sim.load_urdf(path)
    assert _raw.table_difference(sim.joints(body), raw.table) is None
    assert _raw.dynamics_difference(sim, body, raw.dynamics, 1e-7) is None
    assert (
        _raw.frames_difference(_raw.sim_frames(sim, body), raw.frames, _raw.frame_rel(sim.backend))
        is None
    )
    warnings = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert [r.name for r in warnings] == ["simbridge.model.urdf"], [
        r.getMessage() for r in warnings
    ]
    assert re.search(we_say, warnings[0].getMessage()), warnings[0].getMessage()
