"""Robots from outside pybullet_data: the URDFs of example-robot-data (the ``corpus`` extra;
the ``test`` extra installs it too), against raw PyBullet, on every backend.

Every robot raw PyBullet loads loads on every backend with raw PyBullet's joint table (the 17
fields of ``getJointInfo``, the parent frame's quaternion with its sign: ``_raw.table_difference``)
and its link frames at a spawn pose (float32's 2e-7 relative, or the backend's declared
``link_frames_vs_raw`` gap: ``_raw.frames_difference``), and
every line raw PyBullet warns with is said once, by simbridge's URDF reader, on every backend.
The robots sampled by default cover each case (joints whose quaternion MuJoCo's table had
negated, links without ``<inertial>``, an ASCII STL PyBullet leaves out, meshes by
``package://``); ``SIMBRIDGE_FULL_SWEEP=1`` takes all 66 (``python bench/robot_coverage.py``
prints the same comparison as a table, each robot in its own process). Skipped where
example-robot-data is not installed.
"""

from __future__ import annotations

import functools
import glob
import logging
import math
import os
import re
from importlib.metadata import PackageNotFoundError, distribution
from typing import Any

import _raw
import pytest
from _engines import require
from _gaps import gap

from simbridge import exceptions as exc
from simbridge.registry import load_backend

pytestmark = pytest.mark.slow  # whole corpora (or examples' runs): left out of the quick tier

try:
    ROOT = str(
        distribution("example-robot-data").locate_file("cmeel.prefix/share/example-robot-data")
    )
except PackageNotFoundError:  # a test dependency: skipped, or fails in CI (tests/_engines.py)
    require("example-robot-data is not installed (pip install -e '.[corpus]')", module_level=True)
ROOT = os.path.join(ROOT, "robots")
ALL = sorted(
    os.path.relpath(f, ROOT) for f in glob.glob(os.path.join(ROOT, "**", "*.urdf"), recursive=True)
)
POSE = ((0.1, -0.2, 0.3), (0.0, 0.0, math.sin(0.3), math.cos(0.3)))

# raw PyBullet cannot load these (measured, PyBullet 3.2.7): simbridge's answer on every backend
# (None: it loads), or the gap whose backends answer otherwise and what they raise
RAW_CANNOT: dict[str, tuple[Any, str | None, Any]] = {
    # b3Error "Expected a name for robot"
    "ur_description/urdf/ur3.urdf": (
        (exc.UrdfStructureError, r"ur3\.urdf:6: <robot>: has no name attribute"),
        None,
        None,
    ),
    # its meshes are absolute file:// paths to a machine's /usr/Romeo ("invalid mesh filename
    # extension 'mesh'" for the first, a .mesh)
    "romeo_description/urdf/romeo_laas_small.urdf": (
        (exc.MeshNotFoundError, r"romeo_laas_small\.urdf"),
        None,
        None,
    ),
    # 129 joints: loadURDF returns a body whose every state read fails
    # ("getBasePositionAndOrientation failed"): PyBullet's 127-joint limit; a backend with no
    # joint limit (no "most_joints" gap) loads it, one with a limit refuses it
    "tiago_description/robots/tiago_dual.urdf": (
        None,
        "most_joints",
        (exc.BackendUnsupportedError, r"tiago_dual\.urdf.*129 joints"),
    ),
}
LOADABLE = [f for f in ALL if f not in RAW_CANNOT]
SAMPLE = [
    "double_pendulum_description/urdf/double_pendulum_simple.urdf",
    "icub_description/robots/icub_reduced.urdf",  # 11 joints whose field 15 MuJoCo negated
    "romeo_description/urdf/romeo_small.urdf",  # 26 links without <inertial>, 2 signs
    "simple_humanoid_description/urdf/simple_humanoid.urdf",  # an ASCII STL, no <inertial>
    "so_arm_description/urdf/so100.urdf",  # a sign; .stl meshes by package://
    "talos_data/robots/talos_left_arm.urdf",  # 2 signs; package:/// (three slashes)
    "xarm_description/urdf/xarm7.urdf",  # a link without <inertial>
]
FULL = os.environ.get("SIMBRIDGE_FULL_SWEEP") == "1"

# what raw PyBullet warns with -> what simbridge's reader says on every backend (the raw line's
# named subject fills the pattern)
SAID = [
    (
        re.compile(r"No inertial data for link, using mass=1, .*: (\S+)$"),
        lambda m: rf"link '{re.escape(m.group(1))}' has no <inertial>: simulated with mass 1 kg",
    ),
    (
        re.compile(r"cannot extract mesh from '.*/([^/]+\.stl)'$", re.IGNORECASE),
        lambda m: rf"'[^']*{re.escape(m.group(1))}' is not a binary STL",
    ),
]
# PyBullet's second line about the same .stl (its visual shape converter's): no second warning
SAME_SHAPE_AGAIN = re.compile(r"^issue extracting mesh from COLLADA/STL file .*\.stl$", re.I)


@functools.cache
def _raw_reference(name: str) -> tuple[_raw.RawBody, tuple[str, ...]]:
    """Raw PyBullet's load of ``name`` at POSE and every line it printed (its own wording)."""
    load_backend("pybullet")  # its classifier turns PyBullet's printout into log records
    lines: list[str] = []

    class Keep(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            lines.append(record.getMessage().split("): ", 1)[-1])

    log = logging.getLogger("simbridge.pybullet")
    handler, level = Keep(logging.DEBUG), log.level
    log.addHandler(handler)
    log.setLevel(logging.DEBUG)
    try:
        raw = _raw.raw_load(
            os.path.join(ROOT, name), base_position=POSE[0], base_orientation=POSE[1]
        )
    finally:
        log.removeHandler(handler)
        log.setLevel(level)
    return raw, tuple(lines)


def _expected_warnings(raw_lines: tuple[str, ...]) -> list[str]:
    """The pattern of the warning each raw PyBullet line calls for; a line nothing says fails."""
    wanted = []
    for line in raw_lines:
        if SAME_SHAPE_AGAIN.search(line):
            continue
        for pattern, said in SAID:
            m = pattern.search(line)
            if m:
                wanted.append(said(m))
                break
        else:
            pytest.fail(f"raw PyBullet warns {line!r}: no backend says it")
    return wanted


@pytest.mark.parametrize("name", LOADABLE if FULL else SAMPLE)
def test_every_robot_loads_as_raw_pybullet_loads_it(make_sim, name, caplog):
    raw, raw_lines = _raw_reference(name)
    wanted = _expected_warnings(raw_lines)
    caplog.set_level(logging.DEBUG, logger="simbridge")
    sim = make_sim()
    body = sim.load_urdf(os.path.join(ROOT, name), base_position=POSE[0], base_orientation=POSE[1])
    assert _raw.table_difference(sim.joints(body), raw.table) is None, name
    assert (
        _raw.frames_difference(_raw.sim_frames(sim, body), raw.frames, _raw.frame_rel(sim.backend))
        is None
    ), name
    said = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert all(r.name == "simbridge.model.urdf" for r in said), [r.getMessage() for r in said]
    assert len(said) == len(wanted), ([r.getMessage() for r in said], raw_lines)
    left = [r.getMessage() for r in said]
    for pattern in wanted:  # each raw line said once, in any order
        hit = next((m for m in left if re.search(pattern, m)), None)
        assert hit is not None, (pattern, left)
        left.remove(hit)
        assert re.search(rf"{re.escape(name.rsplit('/', 1)[-1])}:\d+: link ", hit), hit


def test_the_sample_covers_what_the_corpus_holds():
    """Every sampled robot is one raw PyBullet loads; the corpus is the one measured (69 URDFs,
    3 that raw PyBullet cannot load)."""
    assert len(ALL) == 69 and set(SAMPLE) <= set(LOADABLE)


@pytest.mark.parametrize("name", sorted(RAW_CANNOT))
def test_what_raw_pybullet_cannot_load(make_sim, backend, name):
    expected, gap_name, otherwise = RAW_CANNOT[name]
    if gap_name is not None and gap(backend, gap_name) is not None:
        expected = otherwise
    if name != "tiago_description/robots/tiago_dual.urdf":
        p, _ = _raw.raw_client()
        with pytest.raises(p.error):
            _raw.raw_load(os.path.join(ROOT, name))
    sim = make_sim()
    if expected is None:
        body: Any = sim.load_urdf(os.path.join(ROOT, name))
        assert sim.num_joints(body) == 129
        return
    error, message = expected
    with pytest.raises(error, match=message) as info:
        sim.load_urdf(os.path.join(ROOT, name))
    assert "\n" not in str(info.value)
