"""A run of a scenario on one backend, every step recorded: :class:`Trajectory` (one
:class:`BodyTrajectory` per robot), saved and loaded. :func:`~.recording.run` records it.

Only the :class:`simbridge.Sim` interface is used: the same code runs on every backend.
"""

from __future__ import annotations

import csv
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import TrajectoryFileError
from ..scenario import format_timestep
from .outcomes import OutcomeRecord

__all__ = ["BodyTrajectory", "Trajectory", "urdf_sha256"]

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
    from simbridge.model.urdf import resolve_source

    src = resolve_source(source)
    return src.display_name, hashlib.sha256(src.text.encode("utf-8")).hexdigest()
