"""The whole world's state, PhysX's half of ``get_state``/``set_state`` (a part of
:class:`PhysxBackend`): ``snapshot``/``restore`` through PhysX's own record of the world
(``PhysxCpuSystem.pack``/``unpack``) with what it leaves out kept beside it: every moving link's
velocities as PhysX reported them, the static bodies' poses, the limit rows' bookkeeping and the
articulations' root poses (DEPARTURES["snapshot"])."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import sapien

from simbridge.exceptions import SimulationDivergedError

from ..locking import exclusive
from .robots import Robot

if TYPE_CHECKING:
    from .window import Window

__all__ = ["Snapshots"]


def _pose_copy(pose: Any) -> Any:
    """A ``sapien.Pose`` of its own (the entity's may change under a held reference)."""
    return sapien.Pose(pose.p, pose.q)


class Snapshots:
    """``snapshot`` and ``restore`` (a part of :class:`PhysxBackend`)."""

    if TYPE_CHECKING:
        _robots: dict[int, Robot]
        _generation: int
        _system: Any
        _contacts_cache: list[Any] | None
        _restored: list[Robot]
        _diverged: SimulationDivergedError | None
        _window: Window | None

        def _check_idle(self) -> None: ...

        def _refresh_active(self) -> None: ...

    @exclusive
    def snapshot(self) -> Any:
        """See Backend.snapshot.

        PhysX: its own record of the world (``PhysxCpuSystem.pack``: every body's pose and
        velocities, the articulations' joint state), for this world as it is now, with every moving
        link's velocities as PhysX reports them: unpack recomputes those from the joint velocities,
        and they are the link damping law's input (DEPARTURES["snapshot"]).
        """
        velocities = {
            body: np.array(
                [(link.linear_velocity, link.angular_velocity) for link in robot.built.links],
                dtype=np.float32,
            )
            if robot.restored_velocities is None
            else robot.restored_velocities.copy()
            for body, robot in self._robots.items()
            if not robot.static
        }
        # a static body's pose (a plane.urdf teleported) is no part of pack(): kept beside it
        statics = {
            body: _pose_copy(robot.built.entities[0].pose)
            for body, robot in self._robots.items()
            if robot.static
        }
        # the limit rows' bookkeeping (limits.py): whether a robot's joints are looked at before
        # the next step and the PhysX limits moved meanwhile; not derived again at restore, where
        # a joint the step left a hair past its limit (-2e-20 rad) would count as written there
        limits = {
            body: (robot.past_limit, set(robot.moved), [row[1].limit for row in robot.limit_rows])
            for body, robot in self._robots.items()
            if robot.limit_rows and not robot.static
        }
        # each articulation's root pose as it reads: unpack writes the packed one through
        # PhysX's float32 normalisation, which can move its last bit (a teleported orientation)
        roots = {
            body: _pose_copy(robot.built.articulation.root_pose)
            for body, robot in self._robots.items()
            if not robot.static
        }
        return (id(self), self._generation, self._system.pack(), velocities, statics, limits, roots)

    @exclusive
    def restore(self, native: Any) -> bool:
        """See Backend.restore.

        PhysX: unpacks a snapshot of this very world (no load, remove or reset since; False for any
        other), and puts back what it kept beside the blob: the link velocities, the static bodies'
        poses and the limit rows' bookkeeping. PhysX keeps its contact caches out of the blob, and
        unpack derives a floating base's link poses afresh: with a fixed base and no contacts the
        next step is the same bits, else not (see DEPARTURES["snapshot"]).
        """
        self._check_idle()
        self._contacts_cache = None
        if (
            isinstance(native, tuple)
            and len(native) == 7
            and native[0] == id(self)
            and native[1] == self._generation
        ):
            self._system.unpack(native[2])
            for body, pose in native[6].items():
                art = self._robots[body].built.articulation
                now = art.root_pose
                if (now.p != pose.p).any() or (now.q != pose.q).any():
                    # the pose as read, normalised in double: a Pose PhysX keeps as it is
                    q = np.asarray(pose.q, dtype=np.float64)
                    art.root_pose = sapien.Pose(pose.p, q / np.linalg.norm(q))
            for body, pose in native[4].items():
                entity = self._robots[body].built.entities[0]
                now = entity.pose  # written only if moved: PhysX normalises a written pose's
                if (now.p != pose.p).any() or (now.q != pose.q).any():  # quaternion at the step
                    entity.pose = _pose_copy(pose)
            for body, velocities in native[3].items():
                self._robots[body].restored_velocities = velocities.copy()
            self._restored = [self._robots[body] for body in native[3]]
            for body, (past, moved, bounds) in native[5].items():
                robot = self._robots[body]
                for row, bound in zip(robot.limit_rows, bounds, strict=True):
                    if (row[1].limit != bound).any():
                        row[1].limit = bound
                robot.past_limit, robot.moved = past, set(moved)
            self._refresh_active()
            self._diverged = None
            if self._window is not None:
                self._window.sync()
            return True
        return False
