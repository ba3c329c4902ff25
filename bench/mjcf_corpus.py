"""The corpus of MuJoCo users' models on every engine, under both readings of MJCF (issue 33,
item 4): every standalone MJCF file shipped in gymnasium's and dm_control's wheels (the extra
``mjcf-corpus``), each loaded with ``semantics="mujoco"`` and ``semantics="pybullet"`` on
MuJoCo, PyBullet and PhysX, against raw MuJoCo (``MjModel.from_xml_path`` and ``mj_step``).

The files are sorted first (:func:`survey`): a file another corpus file ``<include>``s is a
fragment (listed, not run); a file whose root is not ``<mujoco>`` is not a model (dm_control's
schema); a file raw MuJoCo refuses to compile is listed with MuJoCo's message. Every other file
is a model, and for each reading and engine the bench records:

- **loads**, **refused** (an engine refuses a feature: ``MjcfFeatureUnsupportedError`` or
  ``BackendUnsupportedError``, naming it), **not read** (the reading's own rules refuse the
  file: PyBullet's importer's, reproduced, ``UrdfStructureError``/``MeshNotFoundError``) or
  **fails** (anything else), with the exception's class and text; under PyBullet's reading the
  ``<include>``s PyBullet's importer drops (listed in the manifest's ``ignored``);
- the **joint table**: the movable joints' count, and whether their names are MuJoCo's hinge
  and slide joints in MuJoCo's order (``semantics="mujoco"``) or by name (PyBullet's reading);
- **FK**: the engine's own frame of every body that carries a joint
  (``backends/<engine>/inspect.py``'s ``mjcf_link_frames``) against raw MuJoCo's forward
  kinematics, at ``qpos0`` and at a random ``qpos`` within the joints' limits (max position
  error, m). Under PyBullet's reading the comparable frames are the links named after a MuJoCo
  body (PyBullet's importer names them so; its massless joint links are not MuJoCo's), at the
  load and with every hinge and slide that PyBullet's table names set to MuJoCo's value less
  ``qpos0`` (PyBullet's zero is the file's pose), the base left where the file puts it;
- **hold**: zero controls for 1 s from ``qpos0``: the largest hinge or slide coordinate gap to
  raw MuJoCo over the run (rad or m); a model with ball joints also its largest ball gap (the
  rotation angle between the engine's joint quaternion and raw MuJoCo's, rad: ``ball``);
- **drop** (a model with a free joint): its height after that second against raw MuJoCo's
  (under PyBullet's reading: the base's centre of mass moved, against the free joint's
  position moved);
- **tracking**: ``ctrl_i = mid_i + half_i sin(2 pi t + i)`` on every actuator (``mid``/
  ``half`` of its ``ctrlrange`` when limited, else 0 and 1) for 1 s: the RMS hinge and slide
  gap to raw MuJoCo. Under PyBullet's reading a model has no actuators: its motor actuators
  (gain fixed, no bias, on a joint) are applied as joint torques ``gear * ctrl`` (clamped as
  MuJoCo clamps) with PyBullet's default motors released; other actuators: not run, said why.

Under PyBullet's reading the Sim is given the file's time step and gravity, so the gaps are
the readings', not a time step's. Each model runs in its own process (a crash or a hang is one
model's row). Nothing here is asserted: tests/conformance/test_mjcf_corpus.py asserts a sample.

::

    nice -n 5 .venv/bin/python bench/mjcf_corpus.py --out /tmp/mjcf_corpus
    # writes /tmp/mjcf_corpus.md and /tmp/mjcf_corpus.json; --only SUBSTRING runs some models
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import re
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

ENGINES = ("mujoco", "pybullet", "physx")
READINGS = ("mujoco", "pybullet")
PACKAGES = ("gymnasium", "dm_control")
SECONDS = 1.0
HINGE_SLIDE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))
FREE = int(mujoco.mjtJoint.mjJNT_FREE)
BALL = int(mujoco.mjtJoint.mjJNT_BALL)


# ------------------------------------------------------------------------------ the corpus


def package_dir(name: str) -> Path | None:
    """The installed package's folder, or None when it is not installed."""
    spec = importlib.util.find_spec(name)
    if spec is None or spec.origin is None:
        return None
    return Path(spec.origin).parent


def corpus_files() -> dict[str, Path]:
    """Every ``.xml`` file of the packages, by label ``package/relative/path``."""
    files = {}
    for name in PACKAGES:
        root = package_dir(name)
        if root is None:
            continue
        for path in sorted(root.rglob("*.xml")):
            files[f"{name}/{path.relative_to(root)}"] = path
    return files


def _includes(path: Path) -> list[Path]:
    """The files an MJCF file ``<include>``s (resolved beside it), or [] when not XML."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError:
        return []
    return [(path.parent / e.get("file", "")).resolve() for e in root.iter("include")]


def _short(text: str) -> str:
    """A message with the packages' folders written as their names."""
    for name in PACKAGES:
        root = package_dir(name)
        if root is not None:
            text = text.replace(str(root), name)
    return text


def survey(files: dict[str, Path]) -> dict[str, Any]:
    """Sort the files: ``models`` (labels raw MuJoCo compiles, with at least one joint),
    ``static`` (compiled, no joint: only loading is checked), ``fragments`` (label: the label
    of a file that ``<include>``s it; a fragment compiles to an empty world alone, or not at
    all), ``not_mjcf`` (label: the root tag) and ``mujoco_refuses`` (label: MuJoCo's
    message)."""
    by_path = {p.resolve(): label for label, p in files.items()}
    included = {}
    for label, path in files.items():
        for inc in _includes(path):
            if inc in by_path:
                included.setdefault(by_path[inc], label)
    out: dict[str, Any] = {
        "models": [], "static": [], "fragments": {}, "not_mjcf": {}, "mujoco_refuses": {}
    }  # fmt: skip
    for label, path in files.items():
        tag = ET.parse(path).getroot().tag
        if tag != "mujoco":
            out["not_mjcf"][label] = tag
            continue
        try:
            m = mujoco.MjModel.from_xml_path(str(path))
        except Exception as exc:  # MuJoCo's own refusal, kept as its text
            if label in included:
                out["fragments"][label] = included[label]
            else:
                out["mujoco_refuses"][label] = _short(" ".join(str(exc).split()))
            continue
        if m.njnt == 0 and label in included and m.nbody == 1:
            out["fragments"][label] = included[label]
        else:
            out["models" if m.njnt else "static"].append(label)
    return out


# ------------------------------------------------------------------------ raw MuJoCo


def controls(m: Any, t: float) -> np.ndarray:
    """The fixed pattern: ``mid_i + half_i sin(2 pi t + i)``, shape (nu,)."""
    lo, hi = m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1]
    limited = m.actuator_ctrllimited.astype(bool) & (hi > lo)
    mid = np.where(limited, 0.5 * (lo + hi), 0.0)
    half = np.where(limited, 0.5 * (hi - lo), 1.0)
    return mid + half * np.sin(2.0 * np.pi * t + np.arange(m.nu))


def coords(m: Any) -> np.ndarray:
    """The ``qpos`` addresses of the hinge and slide joints, shape (k,)."""
    return np.array(
        [m.jnt_qposadr[j] for j in range(m.njnt) if m.jnt_type[j] in HINGE_SLIDE], dtype=int
    )


def ball_coords(m: Any) -> np.ndarray:
    """The ``qpos`` addresses of the ball joints' quaternions, shape (k,)."""
    return np.array([m.jnt_qposadr[j] for j in range(m.njnt) if m.jnt_type[j] == BALL], int)


def ball_gap(a: np.ndarray, b: np.ndarray, adr: np.ndarray) -> float:
    """The largest rotation angle (rad) between two runs' ball joints, over the runs: of
    ``qa^-1 qb``, ``2 atan2(|v|, |w|)`` (exact near 0, where ``arccos`` of a dot product is
    1e-7 off)."""
    out = 0.0
    for k in adr:
        qa, qb = a[:, k : k + 4], b[:, k : k + 4]
        w = np.sum(qa * qb, axis=1)  # the real part of conj(qa) qb
        v = qa[:, :1] * qb[:, 1:] - qb[:, :1] * qa[:, 1:] - np.cross(qa[:, 1:], qb[:, 1:])
        out = max(out, float(np.max(2.0 * np.arctan2(np.linalg.norm(v, axis=1), np.abs(w)))))
    return out


def free_adr(m: Any) -> int:
    """The ``qpos`` address of the first free joint, or -1."""
    free = [j for j in range(m.njnt) if m.jnt_type[j] == FREE]
    return int(m.jnt_qposadr[free[0]]) if free else -1


def random_qpos(m: Any, seed: int = 11) -> np.ndarray:
    """A ``qpos`` within the joints' limits (unlimited hinges and slides: ``qpos0`` +- 0.5;
    free: +- 0.2 m and a random orientation; ball: a random orientation), shape (nq,)."""
    rng = np.random.default_rng(seed)
    q = m.qpos0.copy()
    for j in range(m.njnt):
        a, kind = m.jnt_qposadr[j], m.jnt_type[j]
        if kind in HINGE_SLIDE:
            lo, hi = m.jnt_range[j] if m.jnt_limited[j] else (q[a] - 0.5, q[a] + 0.5)
            q[a] = rng.uniform(lo, hi)
        elif kind == FREE:
            q[a : a + 3] += rng.uniform(-0.2, 0.2, 3)
            quat = rng.normal(size=4)
            q[a + 3 : a + 7] = quat / np.linalg.norm(quat)
        else:
            quat = rng.normal(size=4)
            q[a : a + 4] = quat / np.linalg.norm(quat)
    return q


def raw_run(m: Any, pattern: bool, steps: int) -> np.ndarray:
    """Raw MuJoCo from ``qpos0``: ``qpos`` after each step, shape (steps + 1, nq)."""
    d = mujoco.MjData(m)
    out = [d.qpos.copy()]
    for k in range(steps):
        d.ctrl[:] = controls(m, k * m.opt.timestep) if pattern else 0.0
        mujoco.mj_step(m, d)
        out.append(d.qpos.copy())
    return np.array(out)


def raw_frames(m: Any, q: np.ndarray) -> dict[str, np.ndarray]:
    """Raw MuJoCo's body frames (positions (nbody, 3), rotations (nbody, 3, 3)) at ``q``."""
    d = mujoco.MjData(m)
    d.qpos[:] = q
    mujoco.mj_kinematics(m, d)
    return {"xpos": d.xpos.copy(), "xmat": d.xmat.reshape(-1, 3, 3).copy()}


# ---------------------------------------------------------------- MuJoCo's reading


def _frames_error(m: Any, frames: list, ref: dict[str, np.ndarray]) -> list[float]:
    """The largest distance of an engine's anchor frame from MuJoCo's (m) and the largest
    element of the difference of their rotation matrices."""
    if not frames:
        return [float("nan"), float("nan")]
    pos = max(
        np.linalg.norm(p - (ref["xpos"][b] + ref["xmat"][b] @ m.jnt_pos[j]))
        for b, j, p, _rot in frames
    )
    rot = max(np.max(np.abs(r - ref["xmat"][b])) for b, _j, _p, r in frames)
    return [float(pos), float(rot)]


def _link_frames(engine: str, sim: Any) -> list:
    if engine == "pybullet":
        from simbridge.backends.pybullet.inspect import mjcf_link_frames
    elif engine == "physx":
        from simbridge.backends.physx.inspect import mjcf_link_frames
    else:
        from simbridge.backends.mujoco.inspect import mjcf_link_frames
    return mjcf_link_frames(sim)


def _engine_run(sim: Any, m: Any, pattern: bool, steps: int) -> np.ndarray:
    """The Sim's ``qpos`` after each step under zero controls or the pattern."""
    out = [sim.qpos()]
    for k in range(steps):
        if m.nu:
            ctrl = controls(m, k * m.opt.timestep) if pattern else np.zeros(m.nu)
            sim.set_actuator_controls(ctrl)
        sim.step(1)
        out.append(sim.qpos())
    return np.array(out)


def mujoco_reading(engine: str, path: Path, m: Any, refs: dict[str, Any]) -> dict[str, Any]:
    """One engine's row under ``semantics="mujoco"`` (``m`` raw MuJoCo's model)."""

    row: dict[str, Any] = {}
    with _open(engine, path, m, "mujoco") as sim:
        bodies = sim.bodies()
        names = [sim.joint_info(b, j).name for b in bodies for j in range(sim.num_joints(b))]
        row["joints"] = len(names)
        row["names_are_mujocos"] = names == refs["joint_names"]
        overlap = sim.manifest()["departures"].get("initial_penetration")
        if overlap:  # "at qpos0 N pairs of bodies overlap ..., deepest first: 'a'-'b' D m"
            deepest = re.search(r"'-'[^']*' ([\d.]+) m", overlap)
            row["initial_penetration"] = {
                "pairs": int(overlap.split()[2]),
                "deepest": float(deepest.group(1)) if deepest else None,
            }
        if m.njnt:
            row["fk_qpos0"] = _frames_error(m, _link_frames(engine, sim), refs["fk0"])
            sim.set_qpos_qvel(refs["qrand"], np.zeros(m.nv))
            row["fk_random"] = _frames_error(m, _link_frames(engine, sim), refs["fkr"])
    _dynamics(row, engine, path, m, refs)
    return row


def _open(engine: str, path: Path, m: Any, reading: str) -> Any:
    """A Sim with the model loaded under ``reading`` (PyBullet's: the file's time step and
    gravity given to the Sim)."""
    import simbridge

    if reading == "mujoco":
        sim = simbridge.Sim(engine)
        sim.load_mjcf(str(path), semantics="mujoco")
        return sim
    dt, g = float(m.opt.timestep), tuple(map(float, m.opt.gravity))
    sim = simbridge.Sim(engine, timestep=dt, gravity=g)
    sim.load_mjcf(str(path))
    return sim


def _dynamics(row: dict[str, Any], engine: str, path: Path, m: Any, refs: dict) -> None:
    """Hold, drop and tracking under MuJoCo's reading, each in a fresh Sim."""
    import simbridge

    adr, steps, balls = refs["coords"], refs["steps"], ball_coords(m)
    if not adr.size and not balls.size:
        return
    try:
        with _open(engine, path, m, "mujoco") as sim:
            held = _engine_run(sim, m, False, steps)
        if adr.size:
            row["hold"] = float(np.max(np.abs(held[:, adr] - refs["hold"][:, adr])))
        if balls.size:
            row["hold_ball"] = ball_gap(held, refs["hold"], balls)
        if refs["free"] >= 0:
            z = refs["free"] + 2
            row["drop"] = {"engine": float(held[-1, z]), "raw": float(refs["hold"][-1, z])}
        if m.nu:
            with _open(engine, path, m, "mujoco") as sim:
                tracked = _engine_run(sim, m, True, steps)
            gap = tracked[:, adr] - refs["track"][:, adr]
            row["tracking"] = float(np.sqrt(np.mean(gap**2)))
    except simbridge.exceptions.SimulationDivergedError as exc:
        row["diverged"] = " ".join(str(exc).split())[:300]
    except Exception as exc:  # a call the checks need, refused: said with its class
        row["dynamics_error"] = _short(f"{type(exc).__name__}: {exc}")[:300]


# -------------------------------------------------------------- PyBullet's reading


def _pybullet_table(sim: Any, bodies: tuple[int, ...]) -> dict[str, tuple[int, int]]:
    """The movable joints by name: (body, index)."""
    table = {}
    for b in bodies:
        for j in range(sim.num_joints(b)):
            info = sim.joint_info(b, j)
            if int(info.type) != 4:  # JOINT_FIXED
                table[info.name] = (b, j)
    return table


def _pybullet_links(sim: Any, bodies: tuple[int, ...], m: Any) -> dict[int, tuple[int, int]]:
    """The links named after a MuJoCo body: MuJoCo body id -> (body, link)."""
    links = {}
    for b in bodies:
        for j in range(sim.num_joints(b)):
            bid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, sim.joint_info(b, j).link_name)
            if bid > 0:
                links[bid] = (b, j)
    return links


def _pybullet_fk(sim: Any, links: dict, ref: dict[str, np.ndarray]) -> list[float]:
    """The largest position (m) and rotation-matrix element errors of the named links."""
    pos, rot = [], []
    for bid, (b, j) in links.items():
        state = sim.link_state(b, j)
        pos.append(np.linalg.norm(np.array(state.link_frame_position) - ref["xpos"][bid]))
        x, y, z, w = state.link_frame_orientation
        mat = np.empty(9)
        mujoco.mju_quat2Mat(mat, np.array([w, x, y, z], dtype=float))
        rot.append(np.max(np.abs(mat.reshape(3, 3) - ref["xmat"][bid])))
    return [float(max(pos)), float(max(rot))]


def _matched(m: Any, table: dict) -> list[tuple[int, int, int]]:
    """(qpos address, body, joint) of each MuJoCo hinge or slide PyBullet's table names."""
    out = []
    for j in range(m.njnt):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
        if m.jnt_type[j] in HINGE_SLIDE and name in table:
            out.append((int(m.jnt_qposadr[j]), *table[name]))
    return out


def _motor_torques(m: Any, matched: list) -> tuple[list, str | None]:
    """(actuator, body, joint, gear) for each motor actuator, or why tracking cannot run."""
    by_adr = {a: (b, j) for a, b, j in matched}
    out = []
    for i in range(m.nu):
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, i) or f"actuator {i}"
        motor = (
            m.actuator_trntype[i] == mujoco.mjtTrn.mjTRN_JOINT
            and m.actuator_gaintype[i] == mujoco.mjtGain.mjGAIN_FIXED
            and m.actuator_biastype[i] == mujoco.mjtBias.mjBIAS_NONE
            and m.actuator_dyntype[i] == mujoco.mjtDyn.mjDYN_NONE
        )
        if not motor:
            return [], f"actuator {name!r} is not a motor on a joint"
        adr = int(m.jnt_qposadr[m.actuator_trnid[i, 0]])
        if adr not in by_adr:
            return [], f"actuator {name!r}'s joint is not in PyBullet's table"
        gain = m.actuator_gear[i, 0] * m.actuator_gainprm[i, 0]
        out.append((i, *by_adr[adr], gain))
    return out, None


def _torques(m: Any, motors: list, t: float) -> list[tuple[int, int, float]]:
    ctrl = controls(m, t)
    out = []
    for i, b, j, gain in motors:
        c = ctrl[i]
        if m.actuator_ctrllimited[i]:
            c = np.clip(c, *m.actuator_ctrlrange[i])
        f = gain * c
        if m.actuator_forcelimited[i]:
            f = np.clip(f, *m.actuator_forcerange[i])
        out.append((b, j, float(f)))
    return out


def _pybullet_run(sim: Any, m: Any, matched: list, motors: list | None, steps: int) -> Any:
    """Joint coordinates (MuJoCo's: PyBullet's + qpos0) after each step; base z's too."""
    for b, j in {(b, j) for _a, b, j in matched}:
        sim.set_joint_velocity(b, j, 0.0, max_force=0.0)
    adr = [a for a, _b, _j in matched]

    def read() -> np.ndarray:
        return np.array([sim.joint_states(b, j).positions[0] for _a, b, j in matched])

    out, zs = [read() + m.qpos0[adr]], [[s.position[2] for s in _bases(sim)]]
    for k in range(steps):
        for b, j, f in _torques(m, motors or [], k * m.opt.timestep):
            sim.set_joint_torque(b, j, f)
        sim.step(1)
        out.append(read() + m.qpos0[adr])
        zs.append([s.position[2] for s in _bases(sim)])
    return np.array(out), np.array(zs)


def _bases(sim: Any) -> list[Any]:
    return [sim.base_state(b) for b in sim.bodies()]


def pybullet_reading(engine: str, path: Path, m: Any, refs: dict[str, Any]) -> dict[str, Any]:
    """One engine's row under ``semantics="pybullet"``."""

    row: dict[str, Any] = {}
    with _open(engine, path, m, "pybullet") as sim:
        bodies = tuple(sim.bodies())
        table = _pybullet_table(sim, bodies)
        matched = _matched(m, table)
        row["joints"] = len(table)
        row["ignored_includes"] = [
            text
            for body in sim.manifest()["bodies"].values()
            for text in body.get("ignored", [])
            if "<include>" in text
        ]
        row["names_matched"] = f"{len(matched)} of {len(refs['coords'])}"
        links = _pybullet_links(sim, bodies, m)
        row["fk_bodies"] = f"{len(links)} of {m.nbody - 1}"
        if links:
            row["fk_qpos0"] = _pybullet_fk(sim, links, refs["fk0_load"])
            for a, b, j in matched:
                sim.reset_joint_state(b, j, refs["qrand_load"][a] - m.qpos0[a])
            row["fk_random"] = _pybullet_fk(sim, links, refs["fkr_load"])
    if matched:
        _pybullet_dynamics(row, engine, path, m, refs, matched)
    return row


def _pybullet_dynamics(
    row: dict, engine: str, path: Path, m: Any, refs: dict, matched: list
) -> None:
    """Hold, drop and tracking under PyBullet's reading, each in a fresh Sim."""
    import simbridge

    adr, steps = [a for a, _b, _j in matched], refs["steps"]
    try:
        with _open(engine, path, m, "pybullet") as sim:
            held, zs = _pybullet_run(sim, m, matched, None, steps)
        row["hold"] = float(np.max(np.abs(held - refs["hold"][:, adr])))
        if refs["free"] >= 0:
            z = refs["free"] + 2
            # the base whose centre of mass starts nearest the free joint's position
            k = int(np.argmin(np.abs(zs[0] - refs["hold"][0, z])))
            row["drop"] = {
                "engine": float(zs[-1, k] - zs[0, k] + refs["hold"][0, z]),
                "raw": float(refs["hold"][-1, z]),
            }
        motors, why = _motor_torques(m, matched)
        if why is not None or not m.nu:
            row["tracking_not_run"] = why or "no actuators"
            return
        with _open(engine, path, m, "pybullet") as sim:
            tracked, _ = _pybullet_run(sim, m, matched, motors, steps)
        row["tracking"] = float(np.sqrt(np.mean((tracked - refs["track"][:, adr]) ** 2)))
    except simbridge.exceptions.SimulationDivergedError as exc:
        row["diverged"] = " ".join(str(exc).split())[:300]
    except Exception as exc:  # a call the checks need, refused: said with its class
        row["dynamics_error"] = _short(f"{type(exc).__name__}: {exc}")[:300]


# ---------------------------------------------------------------------- one model


def references(m: Any) -> dict[str, Any]:
    """Raw MuJoCo's answers for one model."""
    steps = max(1, round(SECONDS / m.opt.timestep))
    qrand = random_qpos(m)
    # PyBullet's reading moves hinges and slides only: the base stays at qpos0
    qrand_load = m.qpos0.copy()
    adr = coords(m)
    qrand_load[adr] = qrand[adr]
    return {
        "steps": steps,
        "coords": adr,
        "free": free_adr(m),
        "joint_names": [
            mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
            for j in range(m.njnt)
            if m.jnt_type[j] != FREE
        ],
        "qrand": qrand,
        "qrand_load": qrand_load,
        "fk0": raw_frames(m, m.qpos0),
        "fkr": raw_frames(m, qrand),
        "fk0_load": raw_frames(m, m.qpos0),
        "fkr_load": raw_frames(m, qrand_load),
        "hold": raw_run(m, False, steps),
        "track": raw_run(m, True, steps) if m.nu else None,
    }


def _status(exc: Exception) -> str:
    """``refused``: an engine refuses a feature by name; ``not read``: the reading's own rules
    refuse the file (PyBullet's importer's, reproduced); ``fails``: anything else."""
    from simbridge import exceptions as e

    if isinstance(exc, e.MjcfFeatureUnsupportedError | e.BackendUnsupportedError):
        return "refused"
    if isinstance(exc, e.UrdfStructureError | e.MeshNotFoundError):
        return "not read"
    return "fails"


def run_model(label: str, path: Path) -> list[dict[str, Any]]:
    """Every reading on every engine for one model: its rows."""

    m = mujoco.MjModel.from_xml_path(str(path))
    refs = references(m)
    rows = []
    for reading in READINGS:
        for engine in ENGINES:
            t0 = time.perf_counter()
            row: dict[str, Any] = {"model": label, "reading": reading, "engine": engine}
            try:
                do = mujoco_reading if reading == "mujoco" else pybullet_reading
                row.update(do(engine, path, m, refs))
                row["status"] = "loads"
            except Exception as exc:  # recorded with its class: the bench says why
                row.update(status=_status(exc), why=_short(f"{type(exc).__name__}: {exc}"))
            row["seconds"] = round(time.perf_counter() - t0, 2)
            rows.append(row)
    return rows


# ---------------------------------------------------------------------- the report


def _num(x: Any, fmt: str = ".1e") -> str:
    return "" if x is None or (isinstance(x, float) and np.isnan(x)) else format(x, fmt)


def _cells(r: dict[str, Any]) -> list[str]:
    if r["status"] != "loads":
        why = " ".join(r.get("why", "").split())
        return [f"{r['status']}: {why[:110]}", "", "", "", "", ""]
    names = r.get("names_are_mujocos", r.get("names_matched", ""))
    fk0, fkr = r.get("fk_qpos0", [None, None]), r.get("fk_random", [None, None])
    fk = f"{_num(fk0[0])} / {_num(fkr[0])}; rot {_num(fk0[1])} / {_num(fkr[1])}"
    if "fk_bodies" in r:
        fk += f" ({r['fk_bodies']} bodies)"
    drop = r.get("drop")
    drop_s = f"{drop['engine']:.3f} vs {drop['raw']:.3f}" if drop else ""
    track = _num(r.get("tracking"), ".3f") or r.get("tracking_not_run", "")
    hold = _num(r.get("hold"), ".3f")
    if "hold_ball" in r:
        hold = f"{hold}; ball {_num(r['hold_ball'], '.1e')}".lstrip("; ")
    if "diverged" in r:
        hold = f"diverged: {r['diverged'][:60]}"
    if "dynamics_error" in r:
        hold = f"not run: {r['dynamics_error'][:90]}"
    status = "loads"
    if r.get("initial_penetration"):
        ip = r["initial_penetration"]
        status += f" (`initial_penetration`: {ip['pairs']} pairs, {_num(ip['deepest'], '.3f')} m)"
    if r.get("ignored_includes"):
        status += " without its `<include>`s (in the manifest's `ignored`)"
    return [status, f"{r['joints']} ({names})", fk, hold, drop_s, track]


def markdown(rows: list[dict[str, Any]], sorted_: dict[str, Any]) -> str:
    """The table, the totals and the files not run."""
    head = (
        "| model | reading | engine | status | joints (MuJoCo's names) | FK max error qpos0 /"
        " random (m) | hold max gap | drop z after 1 s vs raw (m) | tracking RMS gap |"
    )
    lines = [head, "|" + "---|" * 9]
    for r in rows:
        lines.append("| " + " | ".join([r["model"], r["reading"], r["engine"], *_cells(r)]) + " |")
    lines += ["", totals(rows, sorted_), "", "Fragments (`<include>`d, not run):"]
    lines += [f"- `{f}` (included by `{by}`)" for f, by in sorted(sorted_["fragments"].items())]
    lines += ["", "Not MJCF models:"]
    lines += [f"- `{f}` (root `<{tag}>`)" for f, tag in sorted(sorted_["not_mjcf"].items())]
    lines += ["", "Raw MuJoCo refuses to compile (not counted):"]
    lines += [f"- `{f}`: {msg[:160]}" for f, msg in sorted(sorted_["mujoco_refuses"].items())]
    return "\n".join(lines) + "\n"


def totals(rows: list[dict[str, Any]], sorted_: dict[str, Any]) -> str:
    """One line: loads N of M per engine and reading (M: the models with joints; the static
    ones after a plus)."""
    parts = []
    kinds = [("models", len(sorted_["models"])), ("static", len(sorted_["static"]))]
    for reading in READINGS:
        for engine in ENGINES:
            n = [
                sum(
                    r["status"] == "loads" and r["model"] in sorted_[kind]
                    for r in rows
                    if r["reading"] == reading and r["engine"] == engine
                )
                for kind, _ in kinds
            ]
            parts.append(
                f"{engine}/{reading} {n[0]} of {kinds[0][1]} (+ {n[1]} of {kinds[1][1]} static)"
            )
    return "Totals, loads N of M models, engine/reading: " + "; ".join(parts)


def main() -> None:
    """Parse the command line; run each model in a fresh process; write the report."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="mjcf_corpus", help="writes OUT.md and OUT.json")
    parser.add_argument("--only", default="", help="run the models whose label holds this")
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds per model")
    parser.add_argument("--one", help=argparse.SUPPRESS)
    args = parser.parse_args()
    files = corpus_files()
    if args.one:
        print(json.dumps(run_model(args.one, files[args.one])))
        return
    sorted_ = survey(files)
    rows: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    for label in sorted_["models"] + sorted_["static"]:
        if args.only not in label:
            continue
        rows += _one_process(label, args.timeout)
        print(f"{time.perf_counter() - t0:7.0f} s  {label}", file=sys.stderr, flush=True)
    Path(args.out + ".json").write_text(json.dumps({"corpus": sorted_, "rows": rows}, indent=1))
    text = markdown(rows, sorted_)
    Path(args.out + ".md").write_text(text)
    print(text)


def _one_process(label: str, timeout: float) -> list[dict[str, Any]]:
    """One model's rows from a fresh process; a crash or a timeout is a row saying so."""
    cmd = [sys.executable, __file__, "--one", label]
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        why = f"the model's process ran past {timeout:.0f} s"
        return [_dead(label, why)]
    if done.returncode != 0:
        tail = " ".join(done.stderr.split())[-300:]
        return [_dead(label, f"the model's process ended with code {done.returncode}: {tail}")]
    return json.loads(done.stdout.strip().splitlines()[-1])


def _dead(label: str, why: str) -> dict[str, Any]:
    return {"model": label, "reading": "both", "engine": "all", "status": "fails", "why": why}


if __name__ == "__main__":
    main()
