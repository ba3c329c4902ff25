"""A sample of the corpus of MuJoCo users' models (bench/mjcf_corpus.py runs all of
gymnasium's and dm_control's files) on every engine, under both readings of MJCF: the model
loads or is refused by the feature's name; under MuJoCo's reading its joints are MuJoCo's in
MuJoCo's order and the engine's own link frames are raw MuJoCo's forward kinematics within
1e-6 m, at ``qpos0`` and at a random ``qpos`` within the limits; under PyBullet's reading the
links named after MuJoCo bodies are MuJoCo's frames moved by one translation of the whole
model (PyBullet's importer's placement of the base), within 1e-6 m.

The sample: Gymnasium's ant (a free-base walker), walker2d (planar: two slides and a hinge as
its root), humanoid (tendons: refused on PyBullet and PhysX under MuJoCo's reading) and
dm_control's suite cartpole (``<include>``s its common files; its joints take their type
from a ``<default>`` class, which PyBullet's importer does not read)."""

from __future__ import annotations

import importlib
import importlib.util
from pathlib import Path

import mujoco
import numpy as np
import pytest
from _gaps import steps_mujocos_reading_raw

import simbridge
from simbridge.exceptions import MjcfFeatureUnsupportedError, UrdfStructureError

GYM = ("gymnasium", "envs/mujoco/assets")
DMC = ("dm_control", "suite")
# (package, folder, file): each names what it covers in the module docstring
SAMPLE = {
    "ant": (*GYM, "ant.xml"),
    "walker2d": (*GYM, "walker2d.xml"),
    "humanoid": (*GYM, "humanoid.xml"),
    "cartpole": (*DMC, "cartpole.xml"),
}
# MuJoCo's reading on an engine that is not MuJoCo: the refusal's pattern
REFUSED = {"humanoid": r"<tendon> \('left_hipknee'"}
# PyBullet's reading: the one translation (m, world) between the links named after MuJoCo
# bodies and MuJoCo's frames at qpos0, measured the same on every engine (bench/mjcf_corpus.py):
# the ant's torso has its centre of mass at its frame; walker2d's torso stands 1.25 m higher
# (rootz's `ref` is 1.25); the humanoid's base is moved by minus the middle of its torso's last
# fromto geom ('uwaist', (-0.01, 0, -0.12)): PyBullet puts a free base's centre of mass at the
# body's pos (docs/mjcf_sdf.md)
PYBULLET_SHIFT = {
    "ant": (0.0, 0.0, 0.0),
    "walker2d": (0.0, 0.0, 1.25),
    "humanoid": (0.01, 0.0, 0.12),
}
# PyBullet's reading refuses the file: the pattern (PyBullet's importer reads a joint's type
# from the joint or the top-level <default> only; cartpole's comes from a class)
PYBULLET_NOT_READ = {"cartpole": r"<joint 'hinge_1'>: has no type attribute"}


def _path(name: str) -> str:
    package, folder, file = SAMPLE[name]
    spec = importlib.util.find_spec(package)
    if spec is None or spec.origin is None:
        pytest.skip(f"{package} is not installed: pip install 'simbridge[mjcf-corpus]'")
    return str(Path(spec.origin).parent / folder / file)


def _reads_mujoco(backend: str) -> bool:
    return "mujoco" in simbridge.registry.load_backend(backend).semantics


def _link_frames(backend: str, sim: simbridge.Sim) -> list:
    """The engine's own link frames, from the ``inspect`` module beside the backend's class
    (or the class it derives from: a backend registered under a new name reads as its base)."""
    frames = None
    for cls in simbridge.registry.load_backend(backend).__mro__:
        package = cls.__module__.rpartition(".")[0]
        if package and frames is None:
            try:
                inspect = importlib.import_module(f"{package}.inspect")
            except ImportError:
                continue
            frames = getattr(inspect, "mjcf_link_frames", None)
    if frames is None:
        pytest.skip(f"backend {backend!r} has no inspect.mjcf_link_frames to read its frames")
    return frames(sim)


def _frames_error(m: mujoco.MjModel, frames: list, q: np.ndarray) -> tuple[float, float]:
    """The largest anchor position error (m) and rotation-matrix element error."""
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    pos = max(
        float(np.linalg.norm(p - (d.xpos[b] + d.xmat[b].reshape(3, 3) @ m.jnt_pos[j])))
        for b, j, p, _r in frames
    )
    rot = max(float(np.max(np.abs(r - d.xmat[b].reshape(3, 3)))) for b, _j, _p, r in frames)
    return pos, rot


def _random_qpos(m: mujoco.MjModel) -> np.ndarray:
    rng = np.random.default_rng(5)
    q = m.qpos0.copy()
    for j in range(m.njnt):
        a = m.jnt_qposadr[j]
        if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE:
            q[a : a + 3] += rng.uniform(-0.2, 0.2, 3)
            quat = rng.normal(size=4)
            q[a + 3 : a + 7] = quat / np.linalg.norm(quat)
        else:
            lo, hi = m.jnt_range[j] if m.jnt_limited[j] else (q[a] - 0.5, q[a] + 0.5)
            q[a] = rng.uniform(lo, hi)
    return q


@pytest.mark.parametrize("name", sorted(SAMPLE))
def test_mujocos_reading_loads_with_mujocos_frames_or_refuses_by_name(
    backend: str, name: str
) -> None:
    """MuJoCo's reading: loads with MuJoCo's joints and frames (within 1e-6 m, both at
    ``qpos0`` and at a random ``qpos``), or, on an engine that is not MuJoCo, is refused with
    the feature's name (the world left empty)."""
    if not _reads_mujoco(backend):
        pytest.skip(f"{backend!r} does not declare MuJoCo's reading of MJCF")
    path = _path(name)
    m = mujoco.MjModel.from_xml_path(path)
    with simbridge.Sim(backend) as sim:
        if name in REFUSED and not steps_mujocos_reading_raw(backend):
            with pytest.raises(MjcfFeatureUnsupportedError, match=REFUSED[name]):
                sim.load_mjcf(path, semantics="mujoco")
            assert sim.bodies() == []
            return
        bodies = sim.load_mjcf(path, semantics="mujoco")
        names = [sim.joint_info(b, j).name for b in bodies for j in range(sim.num_joints(b))]
        assert names == [
            mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
            for j in range(m.njnt)
            if m.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE
        ]
        frames = _link_frames(backend, sim)
        assert len(frames) == len({b for b, _j, _p, _r in frames}) > 0
        assert max(_frames_error(m, frames, m.qpos0)) < 1e-6
        q = _random_qpos(m)
        sim.set_qpos_qvel(q, np.zeros(m.nv))
        moved = _link_frames(backend, sim)
        assert max(_frames_error(m, moved, q)) < 1e-6
        # the random state moved every link: the check at q is not the one at qpos0 again
        assert all(
            np.linalg.norm(a[2] - b[2]) + np.abs(a[3] - b[3]).max() > 1e-3
            for a, b in zip(frames, moved, strict=True)
        )


@pytest.mark.parametrize("name", sorted(SAMPLE))
def test_pybullets_reading_loads_with_mujocos_joints_or_is_not_read(
    backend: str, name: str
) -> None:
    """PyBullet's reading: every MuJoCo hinge and slide is a movable joint of the same name,
    and the links named after MuJoCo bodies sit at MuJoCo's frames moved by one translation
    (PYBULLET_SHIFT) within 1e-6 m; or the file is refused with PyBullet's importer's rule."""
    path = _path(name)
    m = mujoco.MjModel.from_xml_path(path)
    with simbridge.Sim(backend) as sim:
        if name in PYBULLET_NOT_READ:
            with pytest.raises(UrdfStructureError, match=PYBULLET_NOT_READ[name]):
                sim.load_mjcf(path)
            return
        bodies = sim.load_mjcf(path)
        movable, offsets = set(), []
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        for b in bodies:
            for j in range(sim.num_joints(b)):
                info = sim.joint_info(b, j)
                if int(info.type) != 4:  # JOINT_FIXED
                    movable.add(info.name)
                bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, info.link_name)
                if bid > 0:
                    offsets.append(np.array(sim.link_state(b, j).link_frame_position) - d.xpos[bid])
    hinges = {
        mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
        for j in range(m.njnt)
        if m.jnt_type[j] in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)
    }
    assert hinges <= movable
    assert len(offsets) >= len(hinges) // 2
    np.testing.assert_allclose(offsets, np.tile(PYBULLET_SHIFT[name], (len(offsets), 1)), atol=1e-6)
