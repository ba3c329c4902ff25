"""The errors :mod:`simbridge.envs` raises beside the core's (:mod:`simbridge.exceptions`): each a
:class:`~simbridge.SimbridgeError` and the matching built-in, its message built from context."""

from __future__ import annotations

from collections.abc import Sequence

from simbridge.exceptions import (
    InvalidArgumentError,
    SimbridgeError,
    UnknownBackendError,
    UnknownJointError,
)

__all__ = [
    "ActionError",
    "NormalisationFileError",
    "PolicyError",
    "PolicyRuntimeMissingError",
    "TaskFileError",
    "TaskJointError",
    "UnknownTrainingEngineError",
]


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


class TaskJointError(TaskFileError, UnknownJointError):
    """A joint a task names (``action.joints``, a robot's ``released`` or ``joint_positions``,
    ``randomisation.joints``) that its robot lacks: the task's file, the key and its line where
    the task was read from a file, then the robot's own message (its joints, a close name).

    Both a :class:`TaskFileError` and an :class:`~simbridge.exceptions.UnknownJointError`.

    Args:
        file: the task's file, or ``<task NAME>`` for a task made in Python.
        key: the dotted key path (``action.joints``).
        cause: the robot's lookup error.
        line: the key's 1-based line in the file, or None.
    """

    def __init__(self, file: str, key: str, cause: UnknownJointError, line: int | None = None):
        self.file = file
        self.key = key
        self.line = line
        where = file if line is None else f"{file}:{line}"
        # both parents build their message from other arguments: set this one directly
        SimbridgeError.__init__(self, f"{where}: key {key!r}: {cause}")


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


class PolicyError(SimbridgeError, ValueError):
    """A policy that cannot be loaded or does not fit the task: a bad ``module:callable``, a file
    that does not load, an output or input of another size than the task's layout.

    Args:
        policy: the policy as given (a path or ``module:callable``).
        detail: what is wrong and what would be right.
    """

    def __init__(self, policy: str, detail: str):
        self.policy = policy
        super().__init__(f"policy {policy!r}: {detail}")


class NormalisationFileError(SimbridgeError, ValueError):
    """A policy's observation statistics file (Stable-Baselines3's ``VecNormalize.save``
    pickle, ``simbridge sim2sim --normalisation``) that cannot be read, is no such file, or does
    not fit the task's observation.

    Args:
        file: the file as given (or as found beside the policy).
        detail: what is wrong and what would be right (both layouts where sizes differ).
    """

    def __init__(self, file: str, detail: str):
        self.file = file
        super().__init__(f"normalisation file {file!r}: {detail}")


class PolicyRuntimeMissingError(SimbridgeError, ImportError):
    """A policy file whose runtime is not installed (onnxruntime, torch, stable-baselines3).

    Args:
        policy: the policy file.
        kind: the file's kind (``ONNX``, ``TorchScript``, ``Stable-Baselines3``).
        install: what to install (``pip install onnxruntime``).
    """

    def __init__(self, policy: str, kind: str, install: str):
        self.policy = policy
        super().__init__(
            f"policy {policy!r}: a {kind} file needs a runtime that is not installed: {install}"
        )


class UnknownTrainingEngineError(UnknownBackendError):
    """A training engine (``--trained-on``) that is no registered backend and not of the form
    ``external:NAME``, which a policy trained outside simbridge takes.

    Args:
        name: the backend asked for.
        available: the registered backends (listed in the message, the closest suggested).
    """

    def __init__(self, name: str, available: Sequence[str]):
        super().__init__(name, available)
        self.args = (
            f"trained_on: {self.args[0]}; a policy trained outside simbridge is named "
            "external:NAME (external:isaaclab, external:mujoco-playground, external:gymnasium)",
        )
