"""MJCF and SDF through ``Sim.load_mjcf``/``Sim.load_sdf``: errors naming the file, the line and
the element; text sources; PyBullet's collision filter on both engines; removal; the manifest;
MJCF robots in comparison scenarios. (Every pybullet_data file against raw PyBullet:
tests/conformance/test_mjcf_sdf.py.)"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

import simbridge
from simbridge import exceptions as exc
from simbridge.compare.errors import ScenarioError
from simbridge.compare.scenario import dumps_scenario, loads_scenario
from simbridge.model.scene_reader import parse_scene

BACKENDS = ("pybullet", "mujoco")

HINGED = """<mujoco model="m">
  <worldbody>
    <body name="a" pos="0 0 1">
      <geom type="box" size="0.1 0.1 0.1"/>
      <body name="b" pos="0 0 -0.3">
        <joint name="j1" type="hinge" axis="0 1 0"/>
        <joint name="j2" type="hinge" axis="1 0 0"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.05"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def mjcf(body: str, top: str = "") -> str:
    return f'<mujoco model="t">{top}\n<worldbody>\n{body}\n</worldbody>\n</mujoco>\n'


# ---------------------------------------------------------------- the reading


def test_a_body_with_two_joints_is_three_links():
    (body,) = parse_scene(HINGED, "mjcf")
    assert [(j.name, j.type, j.parent, j.child) for j in body.joints] == [
        ("j1", "continuous", "a", "link0_2"),
        ("j2", "continuous", "link0_2", "link0_3"),
        ("jointfix_0_3", "fixed", "link0_3", "b"),
    ]
    masses = {link.name: link.inertial.mass for link in body.links}
    assert masses["link0_2"] == masses["link0_3"] == 0.0  # PyBullet's massless links
    assert masses["a"] == pytest.approx(1000 * 0.2**3, rel=1e-6)  # density 1000, float32 sizes
    # the root: a free base at the body's pos (its inertial frame is the body frame)
    assert body.base_position == (0.0, 0.0, 1.0)


@pytest.mark.parametrize(
    ("text", "error", "message"),
    [
        (
            mjcf(
                '<body name="a"><geom type="sphere" size="0.1"/>\n<body name="b">\n'
                '<joint name="ball" type="ball"/><geom type="sphere" size="0.1"/></body></body>'
            ),
            exc.UnsupportedJointError,
            r"<MJCF text>:5: joint 'ball': joint type 'ball' is not supported; supported types: "
            r"\['hinge', 'slide', 'fixed', 'free \(on a top-level body\)'\]",
        ),
        (
            mjcf(
                '<body name="a"><geom type="sphere" size="0.1"/>\n<body name="b">\n'
                '<joint type="free"/><geom type="sphere" size="0.1"/></body></body>'
            ),
            exc.UnsupportedJointError,
            r"<MJCF text>:5: joint '<unnamed>': joint type 'free' is not supported",
        ),
        (
            mjcf(
                '<body name="a">\n<joint name="j" axis="0 0 1"/><geom type="sphere" size="1"/>'
                "</body>"
            ),
            exc.UrdfStructureError,
            r"<MJCF text>:4: <joint 'j'>: has no type attribute: PyBullet does not read it",
        ),
        (
            mjcf(
                '<body name="a">\n<joint name="j" type="hinge" limited="true"/>'
                '<geom type="sphere" size="1"/></body>'
            ),
            exc.UrdfStructureError,
            r"<MJCF text>:4: <joint 'j'>: limited but has no range attribute \(PyBullet's "
            r"importer crashes on it\)",
        ),
        (
            mjcf(
                '<body name="a">\n<joint name="j" type="hinge" axis="0 0"/>'
                '<geom type="sphere" size="1"/></body>'
            ),
            exc.UrdfStructureError,
            r"<MJCF text>:4: <joint 'j'> axis: axis must not be zero",
        ),
        (
            mjcf(
                '<body name="a"><geom type="sphere" size="1"/></body>\n'
                '<body name="a"><geom type="sphere" size="1"/>\n<body name="a"/></body>'
            ),
            exc.UrdfStructureError,
            r"<MJCF text>:5: body 'a': the name is used twice in one body \(also line 4\)",
        ),
        (
            mjcf('<body name="a">\n<geom type="sphere" size="nan"/></body>'),
            exc.UrdfStructureError,
            r"<MJCF text>:4: <geom>: numbers must be finite",
        ),
        (
            mjcf("<light/>"),
            exc.UrdfStructureError,
            r"<MJCF text>:1: <mujoco>: has no <body> or <geom> in <worldbody>",
        ),
        (
            "<robot name='r'/>",
            exc.UrdfStructureError,
            r"<MJCF text>:1: <robot>: the root element of an MJCF file must be <mujoco>",
        ),
        (
            "<mujoco><worldbody><body></worldbody></mujoco>",
            exc.UrdfParseError,
            r"<MJCF text>: malformed MJCF XML: mismatched tag: line 1, column 27",
        ),
    ],
)
def test_mjcf_errors_name_the_file_the_line_and_the_element(text, error, message):
    with pytest.raises(error, match=message) as info:
        parse_scene(text, "mjcf")
    assert "\n" not in str(info.value)


SDF_LINK = (
    '<link name="{0}"><inertial><mass>1</mass><inertia><ixx>1</ixx><iyy>1</iyy>'
    "<izz>1</izz></inertia></inertial></link>"
)


def sdf(model: str) -> str:
    return f'<sdf version="1.6"><world name="w">\n<model name="m">\n{model}\n</model></world></sdf>'


@pytest.mark.parametrize(
    ("text", "error", "message"),
    [
        (
            sdf(
                SDF_LINK.format("a")
                + SDF_LINK.format("b")
                + '\n<joint name="s" type="spherical"><parent>a</parent><child>b</child></joint>'
            ),
            exc.UnsupportedJointError,
            r"<SDF text>:4: joint 's': joint type 'spherical' is not supported",
        ),
        (
            sdf(SDF_LINK.format("a") + SDF_LINK.format("b")),
            exc.UrdfStructureError,
            r"<SDF text>:2: model 'm': 2 root links \['a', 'b'\]; PyBullet crashes on a model",
        ),
        (
            sdf(
                SDF_LINK.format("a")
                + SDF_LINK.format("b")
                + '\n<joint name="r" type="revolute"><parent>a</parent><child>b</child>'
                "<axis><xyz>0 0 1</xyz></axis></joint>"
            ),
            exc.UrdfStructureError,
            r"<SDF text>:4: joint 'r': a revolute joint needs <axis><limit>",
        ),
        (
            sdf('<link name="a">\n<pose/></link>'),
            exc.UrdfStructureError,
            r"<SDF text>:4: link 'a' <pose>: is empty; a value was expected \(PyBullet's "
            r"importer crashes on it\)",
        ),
        (
            sdf(
                '<link name="a"><collision name="c">\n<geometry><mesh><uri>no.stl</uri></mesh>'
                "</geometry></collision></link>"
            ),
            exc.MeshNotFoundError,
            r"<SDF text>:4: link 'a' <collision> #0 <mesh>: mesh file 'no\.stl' not found",
        ),
    ],
)
def test_sdf_errors_name_the_file_the_line_and_the_element(text, error, message):
    with pytest.raises(error, match=message) as info:
        parse_scene(text, "sdf")
    assert "\n" not in str(info.value)


def _nested_bodies(depth: int) -> str:
    body = '<body><joint type="hinge"/><geom type="sphere" size="0.01" mass="1"/>'
    return "<mujoco><worldbody>" + body * depth + "</body>" * depth + "</worldbody></mujoco>"


@pytest.mark.parametrize("depth", [97, 3000])
def test_bodies_nested_deeper_than_pybullet_reads_are_refused(depth):
    """Raw PyBullet's loadMJCF refuses 97 bodies nested with a geom in the last
    (XML_ELEMENT_DEPTH_EXCEEDED: the last body, holding elements, at depth 99) and loads 96
    (measured on 3.2.7); the reader refuses the same on every backend, without recursing (3000
    deep was a raw RecursionError)."""
    with pytest.raises(exc.UrdfStructureError, match=rf"<joint>: elements nested {depth + 2} "
                       r"deep: PyBullet's XML reader refuses more than 98"):  # fmt: skip
        parse_scene(_nested_bodies(depth), "mjcf")
    nested_defaults = (
        "<mujoco>" + "<default>" * (depth + 2) + "</default>" * (depth + 2) + "</mujoco>"
    )
    with pytest.raises(exc.UrdfStructureError, match=r"elements nested \d+ deep"):
        parse_scene(nested_defaults, "mjcf")


def _nested_sdf(depth: int) -> str:
    """An SDF model whose link holds elements nested to ``depth`` (<sdf> counting 1)."""
    inertia = "".join(
        f"<{k}>{v}</{k}>"
        for k, v in zip(("ixx", "iyy", "izz", "ixy", "ixz", "iyz"), (1, 1, 1, 0, 0, 0), strict=True)
    )
    inner = "<x>" * (depth - 3) + "</x>" * (depth - 3)
    return (f'<sdf version="1.6"><model name="m"><link name="a"><inertial><mass>1</mass>'
            f"<inertia>{inertia}</inertia></inertial>{inner}</link></model></sdf>")  # fmt: skip


@pytest.mark.parametrize("depth", [100, 5000])
def test_sdf_nested_deeper_than_pybullet_reads_is_refused(depth):
    """Raw PyBullet's loadSDF refuses elements nested that deep (XML_ELEMENT_DEPTH_EXCEEDED,
    measured on 3.2.7); the SDF reader had no check (a very deep file reached the PyBullet
    backend's recursive writer)."""
    with pytest.raises(exc.UrdfStructureError, match=rf"<x>: elements nested {depth} deep: "
                       r"PyBullet's XML reader refuses more than 98.*an SDF file"):  # fmt: skip
        parse_scene(_nested_sdf(depth), "sdf")
    (body,) = parse_scene(_nested_sdf(98), "sdf")  # as deep as raw PyBullet loads it
    # an empty-element tag counts as its parent, as PyBullet counts it (<x/> at 99 loads there)
    (body,) = parse_scene(_nested_sdf(98).replace("<x></x>", "<x><x/></x>"), "sdf")


def test_bodies_nested_as_deep_as_pybullet_reads_load():
    (model,) = parse_scene(_nested_bodies(96), "mjcf")  # 99 elements deep
    assert len(model.joints) == 192  # a hinge and a weld per body


def test_a_missing_file_is_named_as_mjcf():
    with pytest.raises(exc.UrdfNotFoundError, match=r"^MJCF 'nosuch\.xml' is neither a file"):
        parse_scene("nosuch.xml", "mjcf")


# ---------------------------------------------------------------- on both engines


@pytest.mark.parametrize("backend", BACKENDS)
def test_text_loads_through_a_temporary_file_that_is_removed(backend, tmp_path, monkeypatch):
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    with simbridge.Sim(backend) as sim:
        (body,) = sim.load_mjcf(HINGED)
        assert [sim.joint_info(body, j).name for j in range(3)] == ["j1", "j2", "jointfix_0_3"]
        sim.step(10)
        (box,) = sim.load_sdf(sdf(SDF_LINK.format("a")))
        assert sim.body_name(box) == "m" and sim.num_joints(box) == 0
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("backend", BACKENDS)
def test_two_ants_pass_through_each_other_as_in_pybullet(backend):
    """The ant's geoms are contype 1, conaffinity 0: PyBullet pairs two links when
    group_a & mask_b or group_b & mask_a, so two ants never touch (both fall through each other
    onto the plane, which they do touch)."""
    with simbridge.Sim(backend) as sim:
        plane = sim.load_urdf("plane.urdf")
        (a,) = sim.load_mjcf("mjcf/ant.xml")
        (b,) = sim.load_mjcf("mjcf/ant.xml")
        sim.step(240)
        assert sim.contact_points(a, b) == ()
        assert sim.contact_points(a, plane) and sim.contact_points(b, plane)
        pa, pb = sim.base_state(a).position, sim.base_state(b).position
        assert pa == pytest.approx(pb, abs=1e-9) and pa[2] == pytest.approx(0.25, abs=2e-3)


@pytest.mark.parametrize("backend", BACKENDS)
def test_scene_bodies_are_removed_and_their_ids_reused(backend):
    with simbridge.Sim(backend) as sim:
        ids = sim.load_mjcf("mjcf/reacher.xml")
        assert ids == tuple(range(8))
        sim.remove(ids[-1])
        sim.remove(ids[-2])
        assert sim.load_mjcf("mjcf/hopper.xml") == (6,)  # PyBullet's pool: last freed first
        sim.step(5)
        sim.reset()
        assert sim.load_sdf("kuka_iiwa/model.sdf") == (0,)


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_manifest_lists_what_pybullet_does_not_read(backend):
    with simbridge.Sim(backend) as sim:
        (ant,) = sim.load_mjcf("mjcf/ant.xml")
        load = sim.manifest()["bodies"][ant]
        assert load["format"] == "mjcf" and load["body_index"] == 0
        assert load["inertia_source"] == "collision_aabb" and load["self_collision"] == "off"
        ignored = "\n".join(load["ignored"])
        assert "line 3: <option>" in ignored  # integrator RK4, timestep 0.01
        assert "line 8: <default><joint> damping='1'" in ignored  # and armature='1'
        assert "line 9: <default><geom> density='5.0'" in ignored  # PyBullet's is 1000
        assert "<geom 'torso_geom'>" not in ignored
        assert "line 61: <actuator>" in ignored


# ---------------------------------------------------------------- scenarios

SCENARIO = """\
name = "t"
[[robots]]
name = "ant"
mjcf = "mjcf/ant.xml"
{extra}
[[phases]]
steps = 2
"""


def test_a_scenario_robot_from_an_mjcf_file_round_trips():
    sc = loads_scenario(SCENARIO.format(extra=""))
    (ant,) = sc.robots
    assert (ant.kind, ant.urdf, ant.body) == ("mjcf", "mjcf/ant.xml", 0)
    assert loads_scenario(dumps_scenario(sc)) == sc


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ("position = [0, 0, 1]", r"robots\[0\]\.position.*not with mjcf: an MJCF file places"),
        ('urdf = "r2d2.urdf"', r"robots\[0\]\.urdf.*not with mjcf"),
        ("body = -1", r"robots\[0\]\.body.*expected an integer >= 0, got -1"),
    ],
)
def test_scenario_mjcf_robot_errors(extra, message):
    with pytest.raises(ScenarioError, match=message):
        loads_scenario(SCENARIO.format(extra=extra))


def test_body_is_only_for_mjcf_robots():
    text = '[[robots]]\nurdf = "r2d2.urdf"\nbody = 1\n[[phases]]\nsteps = 1\n'
    with pytest.raises(ScenarioError, match=r"body.*only for a robot from an MJCF file"):
        loads_scenario(text)


def test_a_body_the_file_does_not_make_is_a_scenario_error():
    from simbridge.compare import run

    sc = loads_scenario(SCENARIO.format(extra="body = 1"))
    with pytest.raises(ScenarioError, match=r"'mjcf/ant\.xml' makes 1 bodies \(0 to 0\), not 1"):
        run(sc, "mujoco")


@pytest.mark.parametrize("backend", BACKENDS)
def test_self_collision_is_loadmjcf_s_flag(backend):
    """Off by default (loadMJCF's flags), on when asked. With ``True`` (exclude the parent only)
    an MJCF body collides with its MJCF parent body, which the massless links of its joints make
    a grandparent: the humanoid's overlapping geoms push apart on both engines; with
    ``"exclude_all_parents"`` (pybullet_envs' choice) they do not."""
    counts = {}
    for mode in (None, "exclude_all_parents", True):
        with simbridge.Sim(backend) as sim:
            (h,) = sim.load_mjcf("mjcf/humanoid_symmetric_no_ground.xml", self_collision=mode)
            assert (
                sim.manifest()["bodies"][h]["self_collision"]
                == {
                    None: "off",
                    "exclude_all_parents": "exclude_all_parents",
                    True: "exclude_parent",
                }[mode]
            )
            sim.step(1)
            counts[mode] = len(sim.contact_points(h, h))
    assert counts[None] == counts["exclude_all_parents"] == 0 and counts[True] > 0


def test_an_mjcf_mesh_that_is_a_directory_says_so(tmp_path):
    (tmp_path / "m.stl").mkdir()
    text = (
        f'<mujoco><asset><mesh name="m" file="{tmp_path}/m.stl"/></asset><worldbody>\n'
        '<body><geom type="mesh" mesh="m"/></body></worldbody></mujoco>'
    )
    with pytest.raises(exc.UrdfStructureError, match=r"<MJCF text>:2: <geom>: mesh file .*m\.stl"
                       r"'.* is a directory, not a regular file"):  # fmt: skip
        parse_scene(text, "mjcf")


def test_an_mjcf_include_is_not_read_and_says_so(caplog):
    """PyBullet's MJCF importer does not read <include> (raw PyBullet 3.2.7 loads the file
    without a word about it); simbridge logs one warning naming the file and every line."""
    import logging

    text = (
        '<mujoco>\n<include file="parts.xml"/>\n<worldbody>\n<include file="more.xml"/>\n'
        '<body><geom type="sphere" size="0.1"/></body></worldbody></mujoco>'
    )
    caplog.set_level(logging.WARNING, logger="simbridge")
    (model,) = parse_scene(text, "mjcf")
    records = [r.getMessage() for r in caplog.records if r.name == "simbridge.model.mjcf"]
    assert records == [
        "<MJCF text>: <include> not read (PyBullet's MJCF importer does not read it; the "
        "included file's elements are not loaded): line 2 file='parts.xml'; line 4 "
        "file='more.xml'"
    ]
    assert "line 2: <include> file='parts.xml'" in model.ignored


def test_an_sdf_include_is_not_read_and_says_so(caplog):
    """PyBullet's SDF importer does not read <include> either: one warning naming the file
    and every line (it was only listed in the manifest's ``ignored``)."""
    import logging

    text = _nested_sdf(4).replace(
        '<model name="m">', '<model name="m">\n<include><uri>model://table</uri></include>\n'
    )
    caplog.set_level(logging.WARNING, logger="simbridge")
    (body,) = parse_scene(text, "sdf")
    records = [r.getMessage() for r in caplog.records if r.name == "simbridge.model.sdf"]
    assert records == [
        "<SDF text>: <include> not read (PyBullet's SDF importer does not read it; the "
        "included model is not loaded): line 2 uri='model://table'"
    ]
    assert any("<include> in <model>" in item for item in body.ignored)


def test_a_file_in_an_installed_python_package_is_named_by_package_uri():
    """``package://NAME/PATH``: PATH under the installed Python package NAME (ROS's scheme,
    as a scenario names a model a package ships); a missing package or file is said."""
    import mujoco

    from simbridge.model.urdf_source import locate

    found, itself = locate("package://mujoco/testdata/model.xml", kind="MJCF")
    assert found == Path(mujoco.__file__).parent / "testdata" / "model.xml" and not itself
    with pytest.raises(exc.UrdfNotFoundError, match="no Python package 'no_such_pkg' is installed"):
        locate("package://no_such_pkg/a.xml", kind="MJCF")
    with pytest.raises(exc.UrdfNotFoundError, match="testdata/no_such.xml"):
        locate("package://mujoco/testdata/no_such.xml", kind="MJCF")
