"""The core's URDF reader: sources, the search path, package:// and PyBullet's link order."""

from __future__ import annotations

import os

import pytest

import simbridge
from simbridge import exceptions as exc
from simbridge.model.urdf import parse_urdf, resolve_source

LINK = '<link name="{n}"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>'  # noqa: E501


def _joint(name: str, parent: str, child: str, jtype: str = "revolute") -> str:
    limit = '<limit lower="-1" upper="1" effort="1" velocity="1"/>' if jtype != "fixed" else ""
    return (
        f'<joint name="{name}" type="{jtype}"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="0 0.2 0"/><axis xyz="0 0 1"/>{limit}</joint>'
    )


# A tree whose joint file order is not its depth-first order: a -> (c -> e), a -> (b -> d).
SHUFFLED = (
    '<robot name="shuffled">'
    + "".join(LINK.format(n=n) for n in "abcde")
    + _joint("j_ac", "a", "c")
    + _joint("j_ab", "a", "b", "prismatic")
    + _joint("j_ce", "c", "e", "continuous")
    + _joint("j_bd", "b", "d", "fixed")
    + "</robot>"
)


def test_link_order_is_pybullets_depth_first_preorder():
    model = parse_urdf(resolve_source(SHUFFLED))
    assert [j.name for j in model.joints] == ["j_ac", "j_ce", "j_ab", "j_bd"]
    assert [link.name for link in model.links] == ["a", "c", "e", "b", "d"]
    # ... and that is the order PyBullet itself gives the same file.
    with simbridge.Sim("pybullet") as sim:
        body = sim.load_urdf(SHUFFLED)
        assert [j.name for j in sim.joints(body)] == ["j_ac", "j_ce", "j_ab", "j_bd"]
        assert [j.parent_index for j in sim.joints(body)] == [-1, 0, -1, 2]


def test_names_resolve_on_the_search_path_with_or_without_suffix():
    a = resolve_source("r2d2.urdf")
    b = resolve_source("r2d2")
    assert a.path == b.path and a.path.parent.name == "robots"
    # Not shipped in robots/, found in pybullet_data:
    assert resolve_source("kuka_iiwa/model.urdf").path.parts[-3] == "pybullet_data"


def test_unknown_source_lists_where_it_looked():
    with pytest.raises(
        exc.UrdfNotFoundError, match=r"URDF 'no_such_robot.urdf' is neither.*robots"
    ):
        resolve_source("no_such_robot.urdf")


def _deep_folder(root, length: int):
    """A folder under ``root`` whose path is at least ``length`` characters long."""
    folder = root
    k = 0
    while len(str(folder)) < length:
        folder = folder / f"folder_{k:02d}_of_a_long_description"
        k += 1
    folder.mkdir(parents=True)
    return folder


def test_a_misspelt_path_is_shown_whole_with_the_file_beside_it(tmp_path):
    """A long path is not cut in the part that is wrong, and the file near its name in the
    same folder is offered (it was ``'/.../robots/panda_descri... (122 characters)'``, the
    name cut off, and no word of the ``panda.urdf`` beside it)."""
    folder = _deep_folder(tmp_path, 110) / "panda_description" / "urdf"
    folder.mkdir(parents=True)
    (folder / "panda.urdf").write_text(SHUFFLED)
    typed = str(folder / "pandaa.urdf")
    assert 120 < len(typed) <= 240
    with pytest.raises(exc.UrdfNotFoundError) as err:
        resolve_source(typed)
    said = str(err.value)
    assert said == (
        f"URDF {typed!r} is neither a file, a name on the search path, nor URDF text "
        f"(did you mean {str(folder / 'panda.urdf')!r}?); searched: [{typed!r}]"
    )


def test_a_wrong_folder_is_found_and_offered_too(tmp_path, monkeypatch):
    (tmp_path / "panda_description" / "urdf").mkdir(parents=True)
    (tmp_path / "panda_description" / "urdf" / "panda.urdf").write_text(SHUFFLED)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(
        exc.UrdfNotFoundError,
        match=r"^URDF 'panda_descriptoin/urdf/Panda\.urdf' is neither a file, a name on the "
        r"search path, nor URDF text \(did you mean 'panda_description/urdf/panda\.urdf'\?\); ",
    ):
        resolve_source("panda_descriptoin/urdf/Panda.urdf")
    # nothing near: no suggestion
    with pytest.raises(exc.UrdfNotFoundError, match=r"URDF text; searched: "):
        resolve_source("zzzz_qqqq.urdf")


def test_a_very_long_path_is_cut_only_in_the_folders_that_exist(tmp_path):
    """Over 240 characters, the middle of the folders that exist gives way to "...": the
    last of them, the first one missing and the file's name stay whole."""
    folder = _deep_folder(tmp_path, 260)
    typed = str(folder / "no_such_folder" / "robot_with_a_long_name.urdf")
    with pytest.raises(exc.UrdfNotFoundError) as err:
        resolve_source(typed)
    shown = err.value.source
    assert "..." in shown and len(shown) <= 240
    assert shown.startswith("/" + typed.split("/")[1] + "/.../")
    assert shown.endswith(f"/{folder.name}/no_such_folder/robot_with_a_long_name.urdf")


def test_searched_lists_each_place_once_in_order(monkeypatch):
    """Run from a folder of the search path, a relative name was listed twice (the working
    directory's try and the search folder's are one path)."""
    monkeypatch.delenv("SIMBRIDGE_URDF_PATH", raising=False)
    robots = simbridge.model.urdf._robots_dir()
    monkeypatch.chdir(robots)
    with pytest.raises(exc.UrdfNotFoundError) as err:
        resolve_source("robots/pandaa.urdf")
    searched = str(err.value).split("searched: ")[1]
    places = [p.strip(" '") for p in searched.strip("[]").split(",")]
    assert places[:3] == [
        str(robots / "robots/pandaa.urdf"),
        str(robots / "robots/pandaa.urdf.urdf"),
        str(simbridge.model.urdf.search_path()[1] / "robots/pandaa.urdf"),
    ]
    assert len(places) == len(set(places)) == 4


def test_package_uri_resolves_against_the_urdfs_own_tree(tmp_path):
    pkg = tmp_path / "my_robot_description"
    (pkg / "urdf").mkdir(parents=True)
    (pkg / "meshes").mkdir()
    (pkg / "meshes" / "body.stl").write_bytes(
        (simbridge.model.urdf._robots_dir() / "l_finger_tip.stl").read_bytes()
    )
    urdf = pkg / "urdf" / "robot.urdf"
    urdf.write_text(
        '<robot name="r"><link name="base"><inertial><mass value="1"/>'
        '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'
        '<visual><geometry><mesh filename="package://my_robot_description/meshes/body.stl"/>'
        "</geometry></visual></link></robot>"
    )
    model = parse_urdf(resolve_source(str(urdf)))
    assert model.base.visuals[0].mesh_path == pkg / "meshes" / "body.stl"
    with simbridge.Sim("pybullet") as sim:
        assert sim.load_urdf(str(urdf)) >= 0


def test_missing_mesh_names_file_link_and_uri(tmp_path):
    urdf = tmp_path / "broken.urdf"
    urdf.write_text(
        '<robot name="r"><link name="base"><visual><geometry>'
        '<mesh filename="package://pkg/meshes/gone.stl"/></geometry></visual></link></robot>'
    )
    with pytest.raises(
        exc.MeshNotFoundError,
        match=r"broken\.urdf:1: link 'base' <visual> #0: "
        r"mesh file 'package://pkg/meshes/gone.stl' not found",
    ):
        parse_urdf(resolve_source(str(urdf)))


@pytest.mark.parametrize(
    ("jtype", "limit", "expected"),
    [
        ("continuous", '<limit effort="1" velocity="1"/>', (0.0, -1.0)),
        ("revolute", '<limit lower="-1" effort="1" velocity="1"/>', (-1.0, -1.0)),
        ("revolute", '<limit lower="-1" upper="2" effort="1" velocity="1"/>', (-1.0, 2.0)),
        ("prismatic", '<limit effort="1" velocity="1"/>', (0.0, -1.0)),
    ],
)
def test_limits_follow_pybullets_reporting(jtype, limit, expected):
    text = (
        '<robot name="r">'
        + LINK.format(n="a")
        + LINK.format(n="b")
        + f'<joint name="j" type="{jtype}"><parent link="a"/><child link="b"/>{limit}</joint>'
        + "</robot>"
    )
    model = parse_urdf(resolve_source(text))
    assert (model.joints[0].lower, model.joints[0].upper) == expected
    with simbridge.Sim("pybullet") as sim:
        info = sim.joint_info(sim.load_urdf(text), 0)
        assert (info.lower_limit, info.upper_limit) == expected


def test_a_line_past_pybullets_line_buffer_is_named_as_the_cause(tmp_path):
    """PyBullet reads a URDF in lines of at most 8191 bytes and breaks a longer one (raw
    PyBullet 3.2.7 refuses this one-line file: XML_ERROR_PARSING_ATTRIBUTE, measured): the
    refusal says so, with the line and its length, not only 'invalid token'."""
    links = "".join(LINK.format(n=f"l{k}") for k in range(60))
    joints = "".join(_joint(f"j{k}", "l0", f"l{k}") for k in range(1, 60))
    text = f'<?xml version="1.0"?><robot name="long">{links}{joints}</robot>'
    path = tmp_path / "long.urdf"
    path.write_text(text)
    with pytest.raises(exc.UrdfParseError) as info:
        parse_urdf(resolve_source(path))
    assert f"line 1 is {len(text)} bytes long" in str(info.value)
    assert "lines of at most 8191 bytes" in str(info.value)
    # the same robot one element per line loads
    parse_urdf(resolve_source(text.replace("><", ">\n<")))


@pytest.mark.parametrize("scale", ["2", "2 2"])
def test_a_mesh_scale_of_fewer_than_three_numbers_warns_as_pybullet_reads_it(
    scale, tmp_path, caplog
):
    """Raw PyBullet 3.2.7 warns "Scale should be a vector3, not single scalar. Workaround
    activated." and scales by the first number on all three axes (measured: '2' and '2 2'
    give the inertia of '2 2 2'); simbridge reads the same and says so in one warning naming
    the file and the line."""
    import logging

    (tmp_path / "m.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n"
    )
    text = (
        '<robot name="r">\n<link name="a">'
        f'<collision><geometry><mesh filename="m.obj" scale="{scale}"/></geometry></collision>'
        "</link>\n</robot>\n"
    )
    path = tmp_path / "scale.urdf"
    path.write_text(text)
    caplog.set_level(logging.WARNING, logger="simbridge.model.urdf")
    model = parse_urdf(resolve_source(path))
    assert model.base.collisions[0].size == (2.0, 2.0, 2.0)
    records = [r for r in caplog.records if r.name == "simbridge.model.urdf"]
    assert len(records) == 1
    assert records[0].getMessage() == (
        f"{path}: read as PyBullet reads it: line 2: link 'a' <collision> #0 <mesh scale> "
        f"{scale!r} read as (2, 2, 2): fewer than 3 numbers, PyBullet's workaround uses the "
        "first for all three"
    )


@pytest.mark.parametrize(
    ("make", "kind"),
    [
        (lambda path: os.mkfifo(path), "a FIFO"),
        (lambda path: os.symlink("/dev/zero", path), "a character device"),
        (lambda path: path.mkdir(), "a directory"),
    ],
    ids=["fifo", "dev-zero", "directory"],
)
def test_a_mesh_path_that_is_not_a_regular_file_says_so(tmp_path, make, kind):
    """Raw PyBullet 3.2.7 waits forever on a FIFO mesh, ends the process on a directory
    (std::bad_alloc) and loads /dev/zero as a link without a shape (measured); simbridge
    refuses all three, saying what the path is (it said 'not found')."""
    make(tmp_path / "m.stl")
    text = (
        '<robot name="r">\n<link name="a">\n'
        '<collision><geometry><mesh filename="m.stl"/></geometry></collision></link></robot>'
    )
    path = tmp_path / "r.urdf"
    path.write_text(text)
    with pytest.raises(exc.UrdfStructureError) as info:
        parse_urdf(resolve_source(path))
    assert str(info.value) == (
        f"{path}:3: link 'a' <collision> #0 <mesh>: mesh file 'm.stl': "
        f"'{tmp_path / 'm.stl'}' is {kind}, not a regular file"
    )


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-16-be", "utf-32"])
def test_a_utf16_urdf_names_its_encoding(tmp_path, encoding):
    """Raw PyBullet 3.2.7 refuses a UTF-16 URDF, with or without a byte-order mark
    (XML_ERROR_PARSING, measured), and loads one with a UTF-8 byte-order mark: the refusal says
    it is the encoding (it said 'invalid token: line 1, column 0')."""
    text = '<robot name="r">\n' + LINK.format(n="a") + "\n</robot>\n"
    path = tmp_path / "wide.urdf"
    path.write_bytes(text.encode(encoding))
    with pytest.raises(exc.UrdfParseError, match=r"wide\.urdf: malformed URDF XML: the file is "
                       r"UTF-(16|32) text .*: PyBullet reads a URDF as UTF-8"):  # fmt: skip
        parse_urdf(resolve_source(path))
    path.write_bytes(b"\xef\xbb\xbf" + text.encode())
    assert parse_urdf(resolve_source(path)).name == "r"


@pytest.mark.parametrize("axis", ["1e300 1e300 0", "0 0 2e154"])
def test_an_axis_too_long_to_normalise_is_refused_on_both_backends(axis):
    """Raw PyBullet 3.2.7 loads <axis xyz="1e300 1e300 0">, reports it as written, and the
    joint never moves (its normalised axis is zero: a velocity motor at 1 rad/s leaves it at 0,
    measured); MuJoCo refused it with 'axis too small'. Both backends refuse it, saying why."""
    text = (
        '<robot name="r">' + LINK.format(n="a") + LINK.format(n="b") + "\n"
        '<joint name="j" type="revolute"><parent link="a"/><child link="b"/>'
        f'<axis xyz="{axis}"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>'
        "</robot>"
    )
    refused = r":2: joint 'j' <axis>: axis \(.*\) is too long to normalise"
    for backend in ("pybullet", "mujoco"):
        with simbridge.Sim(backend) as sim, pytest.raises(exc.UrdfStructureError, match=refused):
            sim.load_urdf(text)
    # a long axis whose squared length is finite loads, normalised by the engines
    assert parse_urdf(resolve_source(text.replace(axis, "0 0 1e150"))).joints[0].axis[2] == 1e150
