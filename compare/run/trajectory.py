"""Running a scenario on one backend and recording every step: :func:`run` and
:class:`Trajectory`.

About 740 lines: :func:`run` (in named steps) and the :class:`Trajectory` it records share the
recording layout (``_Recorder``), and :class:`Trajectory` stays here because the study cache
pickles it under this module's name.

Only the :class:`simbridge.Sim` interface is used: the same code runs on every backend.
"""

from __future__ import annotations

import csv
import hashlib
import json
import sys
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

import simbridge
from simbridge.types import JointType

from ..errors import ScenarioError, TrajectoryFileError
from ..scenario import Command, Phase, Scenario, format_timestep, load_scenario, parse_timestep
from ..scenario.controllers import PhaseControl
from .gains import HeldGains
from .outcomes import OutcomeRecord, evaluate_all

__all__ = ["BodyTrajectory", "Trajectory", "run", "urdf_sha256"]

Progress = Callable[[int, int], None]
"""progress(steps_done, steps_total), called every few steps."""

_BODY_ARRAYS = (
    "base_position",
    "base_orientation",
    "base_linear_velocity",
    "base_angular_velocity",
    "joint_positions",
    "joint_velocities",
    "joint_forces",
    "joint_targets",
    "link_positions",
)
# Recorded beside _BODY_ARRAYS, saved and loaded alike, but kept out of that tuple: the
# trajectory hashes (tests/_trajectory_hashes.py) cover _BODY_ARRAYS alone.
_CONTACT_ARRAYS = ("contact_counts", "contact_normal_forces", "contact_depths")
# Likewise outside the hashes: what the events (compare/events.py) need of the joints.
_JOINT_EXTRAS = ("joint_limits", "joint_max_forces")


@dataclass
class BodyTrajectory:
    """One robot's recorded state, one row per recorded instant (T rows: the initial state, then
    the state after every step).

    Base quantities are those of the URDF root link frame (``Sim.link_state(body, -1)``); the
    angular velocity is world-frame; the linear velocity is that of the base's centre of mass.
    Joints are the movable ones (fixed joints carry no state), in index order.
    """

    name: str
    fixed_base: bool
    joint_indices: np.ndarray  # (J,) int
    joint_names: list[str]  # (J,)
    link_names: list[str]  # (L,) "base" then link 0, 1, ...
    base_position: np.ndarray  # (T, 3) m, world
    base_orientation: np.ndarray  # (T, 4) x, y, z, w
    base_linear_velocity: np.ndarray  # (T, 3) m/s, world
    base_angular_velocity: np.ndarray  # (T, 3) rad/s, world
    joint_positions: np.ndarray  # (T, J) rad or m
    joint_velocities: np.ndarray  # (T, J) rad/s or m/s
    joint_forces: np.ndarray  # (T, J) N·m or N, the motor force of the step that ended there
    joint_targets: np.ndarray  # (T, J) the command's target held during that step; NaN = none
    joint_modes: np.ndarray  # (T, J) int: 0 none, 1 velocity, 2 position, 3 torque
    link_positions: np.ndarray
    """(T, L, 3) m: world position of every link's centre of mass, base first (PyBullet's
    ``linkWorldPosition``, ``Sim.link_state(...).com_position``)."""
    contact_counts: np.ndarray | None = None
    """(T, L) int: contact points of every link (base first) in the step that ended there
    (``Sim.contact_points``, with any body, this robot's other links included); None in a
    trajectory recorded without them."""
    contact_normal_forces: np.ndarray | None = None
    """(T, L) N: the sum of those points' normal forces."""
    contact_depths: np.ndarray | None = None
    """(T, L) m: how deep the link's deepest point of that step went into what it touched (minus
    the smallest ``ContactPoint.distance``; 0 where it stayed apart or touched nothing). Row 1
    holds the contacts found at the spawn pose: how far the robot starts inside something."""
    joint_types: list[str] | None = None
    """(J,) ``revolute``, ``continuous`` or ``prismatic``; None in an older trajectory."""
    joint_limits: np.ndarray | None = None
    """(J, 2) lower, upper position limit (rad or m; NaN: none, as a continuous joint)."""
    joint_max_forces: np.ndarray | None = None
    """(T, J) N·m or N: the ``max_force`` of the velocity or position command in force during
    the step that ended there (commands persist into later phases until replaced, as in the
    engines); NaN: none (no command, or a torque command)."""


@dataclass
class Trajectory:
    """A recorded run: ``time`` (T,) and, per robot, a :class:`BodyTrajectory`.

    ``phases`` lists ``(name, first_row, last_row)``: the rows recorded at the phase's start and
    end (``time[first_row]`` is the start time). Save with :meth:`save` (``.npz``) or
    :meth:`save_csv`; read back with :meth:`load`."""

    scenario: str
    backend: str
    profile: str
    timestep: float
    time: np.ndarray  # (T,) s
    bodies: dict[str, BodyTrajectory]
    subject: str
    phases: list[tuple[str, int, int]]
    wall_time: float = 0.0
    """Seconds spent issuing commands and stepping (recording excluded)."""
    wall_total: float = 0.0
    """Seconds of the whole run: loading, stepping and recording."""
    manifest: dict[str, Any] = field(default_factory=dict)
    outcomes: dict[str, OutcomeRecord] = field(default_factory=dict)
    """The scenario's outcomes measured on this run, by name
    (:func:`simbridge.compare.run.outcomes.evaluate`)."""

    @property
    def body(self) -> BodyTrajectory:
        """The subject robot's trajectory (the one the report follows)."""
        return self.bodies[self.subject]

    @property
    def duration(self) -> float:
        return float(self.time[-1] - self.time[0])

    @property
    def steps(self) -> int:
        return len(self.time) - 1

    @property
    def label(self) -> str:
        from ..scenario import format_timestep

        return f"{self.backend} @ {format_timestep(self.timestep)} s"

    def wall_per_sim_second(self) -> float:
        """Wall-clock seconds per simulated second, commands and steps only."""
        return self.wall_time / self.duration if self.duration > 0 else float("nan")

    # ------------------------------------------------------------ files

    def save(self, path: str | Path) -> Path:
        """Write a ``.npz`` (numpy arrays plus a JSON header); :meth:`load` reads it back."""
        path = Path(path)
        arrays: dict[str, np.ndarray] = {"time": self.time}
        meta: dict[str, Any] = {
            "format": "simbridge.compare.Trajectory/1",
            "scenario": self.scenario,
            "backend": self.backend,
            "profile": self.profile,
            "timestep": self.timestep,
            "subject": self.subject,
            "phases": self.phases,
            "wall_time": self.wall_time,
            "wall_total": self.wall_total,
            "manifest": self.manifest,
            "outcomes": {name: r.to_dict() for name, r in self.outcomes.items()},
            "bodies": {},
        }
        for name, b in self.bodies.items():
            meta["bodies"][name] = {
                "fixed_base": b.fixed_base,
                "joint_names": b.joint_names,
                "link_names": b.link_names,
                "joint_types": b.joint_types,
            }
            arrays[f"{name}/joint_indices"] = b.joint_indices
            arrays[f"{name}/joint_modes"] = b.joint_modes
            for key in _BODY_ARRAYS:
                arrays[f"{name}/{key}"] = getattr(b, key)
            for key in _CONTACT_ARRAYS + _JOINT_EXTRAS:
                if getattr(b, key) is not None:
                    arrays[f"{name}/{key}"] = getattr(b, key)
        arrays["meta"] = np.array(json.dumps(meta, default=_json_default))
        with path.open("wb") as f:
            np.savez_compressed(f, **arrays)  # type: ignore[arg-type]
        return path

    @classmethod
    def load(cls, path: str | Path) -> Trajectory:
        """The trajectory :meth:`save` wrote.

        Raises:
            TrajectoryFileError: an outcome record that is malformed (naming the file and the
                record's key, ``outcomes.<name>.<key>``).
        """
        with np.load(Path(path), allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            outcomes = _outcomes_of(meta.get("outcomes", {}), str(path))
            bodies = {}
            for name, m in meta["bodies"].items():
                bodies[name] = BodyTrajectory(
                    name=name,
                    fixed_base=m["fixed_base"],
                    joint_indices=data[f"{name}/joint_indices"],
                    joint_names=list(m["joint_names"]),
                    link_names=list(m["link_names"]),
                    joint_modes=data[f"{name}/joint_modes"],
                    **{key: data[f"{name}/{key}"] for key in _BODY_ARRAYS},
                    **{k: data[f"{name}/{k}"] for k in _CONTACT_ARRAYS if f"{name}/{k}" in data},
                    **{k: data[f"{name}/{k}"] for k in _JOINT_EXTRAS if f"{name}/{k}" in data},
                    joint_types=m.get("joint_types"),
                )
            return cls(
                scenario=meta["scenario"],
                backend=meta["backend"],
                profile=meta["profile"],
                timestep=meta["timestep"],
                time=data["time"],
                bodies=bodies,
                subject=meta["subject"],
                phases=[(str(n), int(a), int(b)) for n, a, b in meta["phases"]],
                wall_time=meta["wall_time"],
                wall_total=meta["wall_total"],
                manifest=meta["manifest"],
                outcomes=outcomes,
            )

    def columns(self) -> tuple[list[str], np.ndarray]:
        """Flat column names and a (T, C) table of every recorded number (for CSV)."""
        names = ["time"]
        cols = [self.time[:, None]]
        for bname, b in self.bodies.items():
            for key, axes in (
                ("base_position", "xyz"),
                ("base_orientation", "xyzw"),
                ("base_linear_velocity", "xyz"),
                ("base_angular_velocity", "xyz"),
            ):
                names += [f"{bname}.{key}.{a}" for a in axes]
                cols.append(getattr(b, key))
            for key in ("joint_positions", "joint_velocities", "joint_forces", "joint_targets"):
                names += [f"{bname}.{key}.{j}" for j in b.joint_names]
                cols.append(getattr(b, key))
            for i, link in enumerate(b.link_names):
                names += [f"{bname}.link_positions.{link}.{a}" for a in "xyz"]
                cols.append(b.link_positions[:, i, :])
            for key in _CONTACT_ARRAYS:
                if getattr(b, key) is not None:
                    names += [f"{bname}.{key}.{link}" for link in b.link_names]
                    cols.append(getattr(b, key))
            if b.joint_max_forces is not None:
                names += [f"{bname}.joint_max_forces.{j}" for j in b.joint_names]
                cols.append(b.joint_max_forces)
        return names, np.hstack(cols)

    def save_csv(self, path: str | Path) -> Path:
        """One row per recorded instant, one column per number (``r2d2.base_position.x`` ...)."""
        path = Path(path)
        names, table = self.columns()
        with path.open("w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow(names)
            for row in table:
                writer.writerow([repr(float(v)) for v in row])
        return path


def _outcomes_of(raw: Any, file: str) -> dict[str, OutcomeRecord]:
    """A saved header's ``outcomes``: ``{name: record}`` (:meth:`OutcomeRecord.from_dict`)."""
    if not isinstance(raw, dict):
        raise TrajectoryFileError(file, "outcomes", f"expected a table, got {raw!r}")
    out = {}
    for name, record in raw.items():
        r = OutcomeRecord.from_dict(record, file=file, key=f"outcomes.{name}")
        if r.name != name:
            raise TrajectoryFileError(
                file, f"outcomes.{name}.name", f"the record of {name!r} is named {r.name!r}"
            )
        out[name] = r
    return out


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.integer, np.floating)):
        return obj.item()
    if isinstance(obj, Path):
        return str(obj)
    return str(obj)


def urdf_sha256(source: str) -> tuple[str, str]:
    """``(resolved file, sha256 of its text)`` of a URDF as ``Sim.load_urdf`` would read it."""
    from simbridge.urdf import resolve_source

    src = resolve_source(source)
    return src.display_name, hashlib.sha256(src.text.encode("utf-8")).hexdigest()


_MODE_CODE = {"velocity": 1, "position": 2, "torque": 3}


def run(
    scenario: str | Path | Scenario,
    backend: str,
    *,
    timestep: float | str | None = None,
    profile: str | None = None,
    gravity: tuple[float, float, float] | None = None,
    duration: float | None = None,
    progress: Progress | None = None,
    controller: Any = None,
    before_step: Callable[[simbridge.Sim, int], None] | None = None,
) -> Trajectory:
    """Run ``scenario`` on ``backend`` and record every step.

    Args:
        scenario: a shipped scenario name, a TOML path, or a :class:`Scenario`.
        backend: a registered backend name.
        timestep: run at this step instead (s, or ``"1/480"``); each phase keeps its duration,
            so the step counts scale.
        profile: a simbridge profile name instead of the scenario's.
        gravity: instead of the scenario's (m/s²).
        duration: only the first ``duration`` seconds.
        progress: called as ``progress(steps_done, steps_total)`` every few steps.
        controller: a controller to drive every phase in place of the scenario's own: a class
            or factory function defined at a module's top level, a ``"file.py:Name"`` or
            ``"package.module:Name"`` reference, or a
            :class:`~simbridge.compare.controllers.ControllerSpec` (with params and period);
            see :meth:`Scenario.with_controller`.
        before_step: called as ``before_step(sim, row)`` before every step, once its commands
            are issued (the state at ``row`` with the commands in force: what
            :func:`simbridge.compare.resync.resync` takes); its time counts in ``wall_time``.

    Returns:
        The :class:`Trajectory`: T = steps + 1 rows (the state at t = 0, then after each
        step), with the scenario's outcomes measured on it (``outcomes``).

    Raises:
        ScenarioError, SimbridgeError: a bad scenario, an unknown joint, a failed backend.
        ControllerError: a controller that fails (a ScenarioError naming the controller, the
            phase and the time; its ``trajectory`` holds the run recorded up to there).
    """
    t_start = _time.perf_counter()
    sc = _scenario_to_run(scenario, controller, timestep, duration)
    prof = profile or sc.profile
    grav = gravity if gravity is not None else sc.gravity

    sim_prof = sc.sim_profile(backend, prof)  # with the scenario's engine settings, if any
    with simbridge.Sim(backend, gravity=grav, timestep=sc.timestep, profile=sim_prof) as sim:
        ids, hashes = _load_robots(sim, sc)
        recorders = {
            r.name: _Recorder(sim, ids[r.name], r.fixed_base, sc.steps + 1) for r in sc.robots
        }
        plan = _resolve_commands(sim, sc, ids, recorders)
        stopped = partial(_partial, sc, backend, prof)
        phases, wall = _step_phases(sim, sc, ids, recorders, plan, stopped, progress, before_step)
        manifest = _manifest(sim, sc, hashes)
        time = np.arange(sc.steps + 1, dtype=np.float64) * sc.timestep
        bodies = {name: rec.finish(name) for name, rec in recorders.items()}
    tr = Trajectory(
        scenario=sc.name,
        backend=backend,
        profile=prof,
        timestep=sc.timestep,
        time=time,
        bodies=bodies,
        subject=sc.subject,
        phases=phases,
        wall_time=wall,
        wall_total=_time.perf_counter() - t_start,
        manifest=manifest,
    )
    if sc.outcomes:
        tr.outcomes = evaluate_all(sc, tr)
    return tr


_Commands = list[tuple[int, list[int], Command, "_Recorder", list[int]]]
"""A phase's commands resolved: (body, joint indices, command, its body's recorder, the
joints' columns in the recorder)."""


def _scenario_to_run(
    scenario: str | Path | Scenario,
    controller: Any,
    timestep: float | str | None,
    duration: float | None,
) -> Scenario:
    """The scenario :func:`run` runs: with ``controller``, at ``timestep``, cut to
    ``duration`` (each where given).

    Raises:
        ScenarioError: a bad scenario or time step.
    """
    sc = load_scenario(scenario)
    if controller is not None:
        sc = sc.with_controller(controller)
    if timestep is not None:
        try:
            dt = parse_timestep(timestep)
        except ValueError as exc:
            raise ScenarioError(sc._where(), "timestep", str(exc)) from None
        sc = sc.with_timestep(dt)
    if duration is not None:
        sc = sc.truncated(duration)
    return sc


def _drive(sim: simbridge.Sim, sc: Scenario) -> Any:
    """What the phases and controllers command through: the scenario's position gains, written
    for its own step, sent as the same controller at this one (compare/run/gains.py); the Sim
    itself where the steps are the same."""
    if sc.gains_timestep is not None and sc.gains_timestep != sc.timestep:
        return HeldGains(
            sim,
            sc.timestep / sc.gains_timestep,
            where=sc._where(),
            written_for=format_timestep(sc.gains_timestep),
        )
    return sim


def _load_robots(
    sim: simbridge.Sim, sc: Scenario
) -> tuple[dict[str, int], dict[str, dict[str, str]]]:
    """Load every robot of ``sc`` at its initial joint positions.

    Returns:
        Each robot's body id, and its file's name and SHA-256 (the manifest's ``urdf``).
    """
    ids: dict[str, int] = {}
    hashes: dict[str, dict[str, str]] = {}
    for r in sc.robots:
        source = sc.resolve_urdf(r)
        file, digest = urdf_sha256(source)
        hashes[r.name] = {"urdf": r.urdf, "file": file, "sha256": digest}
        body = sc.load_robot(sim, r)
        ids[r.name] = body
        for joint, q in r.joint_positions:
            sim.reset_joint_state(body, joint, q)
    return ids, hashes


def _resolve_commands(
    sim: simbridge.Sim, sc: Scenario, ids: dict[str, int], recorders: dict[str, _Recorder]
) -> list[tuple[Phase, _Commands]]:
    """Every phase with its commands resolved once (:data:`_Commands`).

    Raises:
        ScenarioError: a command to a fixed joint.
    """
    plan = []
    for pi, p in enumerate(sc.phases):
        cmds: _Commands = []
        for ci, c in enumerate(p.commands):
            body, rec = ids[c.robot], recorders[c.robot]
            idx = [sim.joint_index(body, j) for j in c.joints]
            for i in idx:
                if sim.joint_info(body, i).type == JointType.FIXED:
                    raise ScenarioError(
                        str(sc.source or "<scenario>"),
                        f"phases[{pi}].commands[{ci}].joints",
                        f"joint {i} ({sim.joint_info(body, i).name!r}) of robot "
                        f"{c.robot!r} is fixed and takes no command",
                    )
            cmds.append((body, idx, c, rec, rec.columns(idx)))
        plan.append((p, cmds))
    return plan


def _step_phases(
    sim: simbridge.Sim,
    sc: Scenario,
    ids: dict[str, int],
    recorders: dict[str, _Recorder],
    plan: list[tuple[Phase, _Commands]],
    stopped: Callable[..., Trajectory],
    progress: Progress | None,
    before_step: Callable[[simbridge.Sim, int], None] | None,
) -> tuple[list[tuple[str, int, int]], float]:
    """Step every phase of ``plan``, recording each row.

    Args:
        stopped: the run recorded so far, as ``stopped(done, phase, first, row)`` (a
            controller that fails hands it on).

    Returns:
        Each phase's (name, first row, last row), and the seconds spent commanding and
        stepping.
    """
    drive = _drive(sim, sc)
    total = sc.steps
    row = 0
    for rec in recorders.values():
        rec.record(row)
    phases: list[tuple[str, int, int]] = []
    wall = 0.0
    every = max(1, total // 200)
    for pi, (p, cmds) in enumerate(plan):
        first = row
        for body, idx, c, _, _ in cmds:
            if c.mode == "torque":  # release the velocity motor (the profile's brake)
                sim.set_joint_velocity(body, idx, 0.0, max_force=0.0)
        ctl = _start_control(
            sc, pi, drive, ids, recorders, row, partial(stopped, recorders, phases)
        )
        for i in range(p.steps):
            t0 = _time.perf_counter()
            for body, idx, c, _, _ in cmds:
                if c.mode == "velocity":
                    sim.set_joint_velocity(body, idx, c.target, max_force=c.max_force)
                elif c.mode == "position":
                    kw = {k: v for k, v in (("kp", c.kp), ("kd", c.kd)) if v is not None}
                    drive.set_joint_position(body, idx, c.target, max_force=c.max_force, **kw)
                else:
                    sim.set_joint_torque(body, idx, c.target)
            if ctl is not None:
                ctl.before_step(i, row * sc.timestep)
            if before_step is not None:
                before_step(sim, row)
            sim.step()
            wall += _time.perf_counter() - t0
            row += 1
            _record_row(recorders, cmds, row)
            if ctl is not None:
                ctl.record(row)
            if progress is not None and (row % every == 0 or row == total):
                progress(row, total)
        phases.append((p.name, first, row))
    return phases, wall


def _record_row(recorders: dict[str, _Recorder], cmds: _Commands, row: int) -> None:
    """Record row ``row`` of every body, and the commands in force there."""
    for rec in recorders.values():
        rec.record(row)
    for _, _, c, rec, cols in cmds:
        rec.targets[row, cols] = c.target
        rec.modes[row, cols] = _MODE_CODE[c.mode]
        rec.held_force[cols] = np.nan if c.max_force is None else c.max_force
    for rec in recorders.values():
        rec.max_forces[row] = rec.held_force


def _manifest(
    sim: simbridge.Sim, sc: Scenario, hashes: dict[str, dict[str, str]]
) -> dict[str, Any]:
    """The run's manifest: the Sim's, with the robot files, the scenario and the command line."""
    manifest = sim.manifest()
    manifest["urdf"] = hashes
    manifest["scenario"] = {
        "name": sc.name,
        "file": str(sc.source) if sc.source else None,
        "timestep": sc.timestep,
        "steps": sc.steps,
    }
    if sys.argv:
        manifest["command_line"] = list(sys.argv)
    return manifest


def _start_control(
    sc: Scenario,
    pi: int,
    sim: simbridge.Sim,
    ids: dict[str, int],
    recorders: dict[str, _Recorder],
    row: int,
    stopped: Callable[[str, int, int], Trajectory],
) -> PhaseControl | None:
    """Make phase ``pi``'s controller (None: it has none) and start it at row ``row``."""
    p = sc.phases[pi]
    if p.controller is None:
        return None
    by_body = {body: recorders[name] for name, body in ids.items()}

    def columns(body: int, joints: list[int]) -> tuple[_Recorder, list[int]] | None:
        rec = by_body.get(body)
        if rec is None or any(j not in rec._col for j in joints):
            return None
        return rec, rec.columns(joints)

    overridden = {
        (ids[c.robot], sim.joint_index(ids[c.robot], j)) for c in p.commands for j in c.joints
    }
    ctl = PhaseControl(
        p.controller,
        phase=p.name,
        key=f"phases[{pi}].controller",
        file=sc._where(),
        base=sc.folder,
        sim=sim,
        robots=ids,
        columns=columns,
        stopped=stopped,
        overridden=overridden,
    )
    ctl.start(row, row * sc.timestep)
    return ctl


def _partial(
    sc: Scenario,
    backend: str,
    profile: str,
    recorders: dict[str, _Recorder],
    done: list[tuple[str, int, int]],
    phase: str,
    first: int,
    row: int,
) -> Trajectory:
    """The run recorded up to row ``row`` (a run stopped there, in ``phase`` begun at row
    ``first`` after the phases ``done``: T = row + 1 rows)."""
    phases = [*done, (phase, first, row)]
    n = row + 1
    bodies = {}
    for name, rec in recorders.items():
        body = rec.finish(name)
        for f in fields(body):
            value = getattr(body, f.name)
            if f.name in ("joint_indices", "joint_limits"):  # per joint, not per instant
                continue
            if isinstance(value, np.ndarray) and value.ndim and value.shape[0] == len(rec.q):
                setattr(body, f.name, value[:n].copy())
        bodies[name] = body
    return Trajectory(
        scenario=sc.name,
        backend=backend,
        profile=profile,
        timestep=sc.timestep,
        time=np.arange(n, dtype=np.float64) * sc.timestep,
        bodies=bodies,
        subject=sc.subject,
        phases=phases,
        manifest={"stopped_at": {"row": row, "time": row * sc.timestep}},
    )


class _Recorder:
    """Preallocated arrays for one body, filled row by row through the Sim interface."""

    def __init__(self, sim: simbridge.Sim, body: int, fixed_base: bool, rows: int):
        self.sim = sim
        self.body = body
        self.fixed_base = fixed_base
        table = sim.joints(body)
        movable = [j for j in table if j.type != JointType.FIXED]
        self.joint_indices = np.array([j.index for j in movable], dtype=np.intp)
        self.joint_names = [j.name for j in movable]
        self.joint_types = [
            "continuous"
            if j.type == JointType.REVOLUTE and j.lower_limit > j.upper_limit
            else j.type.name.lower()
            for j in movable
        ]
        self.joint_limits = np.array(
            [
                (j.lower_limit, j.upper_limit) if j.lower_limit <= j.upper_limit else (np.nan,) * 2
                for j in movable
            ],
            dtype=np.float64,
        ).reshape(len(movable), 2)
        self.link_names = ["base"] + [j.link_name for j in table]
        self.links = list(range(-1, len(table)))
        n_j, n_l = len(movable), len(self.links)
        self.base = np.empty((rows, 13))
        self.q = np.empty((rows, n_j))
        self.v = np.empty((rows, n_j))
        self.f = np.empty((rows, n_j))
        self.targets = np.full((rows, n_j), np.nan)
        self.modes = np.zeros((rows, n_j), dtype=np.int8)
        self.links_xyz = np.empty((rows, n_l, 3))
        self.contact_counts = np.zeros((rows, n_l), dtype=np.int32)
        self.contact_forces = np.zeros((rows, n_l))
        self.contact_depths = np.zeros((rows, n_l))
        self.max_forces = np.full((rows, n_j), np.nan)
        self.held_force = np.full(n_j, np.nan)  # the max_force of the command in force
        self._col = {int(j): i for i, j in enumerate(self.joint_indices)}

    def columns(self, idx: list[int]) -> list[int]:
        """Columns of the joint arrays for joint indices ``idx`` (all movable)."""
        return [self._col[i] for i in idx]

    def record(self, row: int) -> None:
        sim, body = self.sim, self.body
        base = sim.link_state(body, -1)
        out = self.base[row]
        out[0:3] = base.link_frame_position
        out[3:7] = base.link_frame_orientation
        out[7:10] = base.linear_velocity
        out[10:13] = base.angular_velocity
        self.links_xyz[row, 0] = base.com_position
        for k in range(1, len(self.links)):
            self.links_xyz[row, k] = sim.link_state(body, self.links[k]).com_position
        if len(self.joint_indices):
            js = sim.joint_states(body, self.joint_indices)
            self.q[row] = js.positions
            self.v[row] = js.velocities
            self.f[row] = js.applied_torques
        counts, forces = self.contact_counts[row], self.contact_forces[row]
        depths = self.contact_depths[row]
        for c in sim.contact_points(body):  # A is this body; B another or this one again
            counts[c.link_a + 1] += 1
            forces[c.link_a + 1] += c.normal_force
            depths[c.link_a + 1] = max(depths[c.link_a + 1], -c.distance)
            if c.body_b == body:
                counts[c.link_b + 1] += 1
                forces[c.link_b + 1] += c.normal_force
                depths[c.link_b + 1] = max(depths[c.link_b + 1], -c.distance)

    def finish(self, name: str) -> BodyTrajectory:
        return BodyTrajectory(
            name=name,
            fixed_base=self.fixed_base,
            joint_indices=self.joint_indices,
            joint_names=self.joint_names,
            link_names=self.link_names,
            base_position=self.base[:, 0:3],
            base_orientation=self.base[:, 3:7],
            base_linear_velocity=self.base[:, 7:10],
            base_angular_velocity=self.base[:, 10:13],
            joint_positions=self.q,
            joint_velocities=self.v,
            joint_forces=self.f,
            joint_targets=self.targets,
            joint_modes=self.modes,
            link_positions=self.links_xyz,
            contact_counts=self.contact_counts,
            contact_normal_forces=self.contact_forces,
            contact_depths=self.contact_depths,
            joint_types=self.joint_types,
            joint_limits=self.joint_limits,
            joint_max_forces=self.max_forces,
        )
