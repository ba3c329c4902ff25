"""Running a scenario on one backend and recording every step: :func:`run`, which makes a
:class:`~.trajectory.Trajectory`.

Only the :class:`simbridge.Sim` interface is used: the same code runs on every backend.
"""

from __future__ import annotations

import sys
import time as _time
from collections.abc import Callable
from dataclasses import fields
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

import simbridge
from simbridge.types import JointType

from ..errors import ScenarioError
from ..scenario import Command, Phase, Scenario, format_timestep, load_scenario, parse_timestep
from ..scenario.controllers import PhaseControl
from .gains import HeldGains
from .outcomes import evaluate_all
from .trajectory import BodyTrajectory, Trajectory, urdf_sha256

__all__ = ["run"]

Progress = Callable[[int, int], None]
"""progress(steps_done, steps_total), called every few steps."""

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
        links = sim.link_states(body)  # every link, the base first: self.links' order
        out = self.base[row]
        out[0:3] = links.link_frame_position[0]
        out[3:7] = links.link_frame_orientation[0]
        out[7:10] = links.linear_velocity[0]
        out[10:13] = links.angular_velocity[0]
        self.links_xyz[row] = links.com_position
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
