"""The errors :mod:`simbridge.envs` raises beside the core's (:mod:`simbridge.exceptions`): each a
:class:`~simbridge.SimbridgeError` and the matching built-in, its message built from context."""

from __future__ import annotations

from collections.abc import Sequence

from simbridge.exceptions import InvalidArgumentError, SimbridgeError

__all__ = ["ActionError", "TaskFileError"]


class TaskFileError(SimbridgeError, ValueError):
    """A task file (TOML) is missing, malformed, or says something invalid.

    Args:
        file: the file (or ``<task>``).
        key: the dotted key path (``action.mode``), or None.
        detail: what is wrong and what would be right.
        line: the key's 1-based line in the file, or None.
    """

    def __init__(self, file: str, key: str | None, detail: str, line: int | None = None):
        self.file = file
        self.key = key
        self.line = line
        where = file if line is None else f"{file}:{line}"
        what = f"key {key!r}: " if key else ""
        super().__init__(f"{where}: {what}{detail}")


class ActionError(InvalidArgumentError):
    """An action the task's layout does not take: a wrong shape or a value that is not finite.

    Args:
        detail: what was given.
        task: the task's name.
        joints: the action's joint names, in order.
        mode: the action's mode.
    """

    def __init__(self, detail: str, task: str, joints: Sequence[str], mode: str):
        self.joints = tuple(joints)
        super().__init__(
            "action",
            f"{detail}; task {task!r} takes an action of shape ({len(joints)},), one "
            f"{mode} entry per joint in this order: {list(joints)}",
        )
