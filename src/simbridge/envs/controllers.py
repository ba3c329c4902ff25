"""Reference controllers, one per shipped task: each maps an observation to an action through the
env's contract (it reads its inputs by name from :meth:`SimEnv.contract`'s observation layout),
so it is a policy like any trained one.

::

    env = SimEnv("cartpole", backend="physx")
    ctrl = reference_controller(env)
    obs, _ = env.reset(seed=0)
    while True:
        obs, r, terminated, truncated, info = env.step(ctrl(obs))
        if terminated or truncated:
            break
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from simbridge.sim import Sim

if TYPE_CHECKING:
    from simbridge.envs.env import SimEnv

__all__ = [
    "CONTROLLERS",
    "Gait",
    "HalfCheetahGait",
    "GAITS",
    "AntGait",
    "CartPoleLQR",
    "DriveToGoal",
    "HoldDefault",
    "KukaReachDLS",
    "reference_controller",
]


def _slices(env: SimEnv) -> dict[str, slice]:
    """Observation term name -> its slice in the newest frame (the last ``frame_size`` entries)."""
    obs = env.contract()["observation"]
    off = obs["size"] - obs["frame_size"]
    return {t["name"]: slice(off + t["start"], off + t["start"] + t["size"]) for t in obs["terms"]}


class CartPoleLQR:
    """An LQR on the cart-pole linearised about upright (cart 1 kg, pole 0.1 kg of 1 m, its
    inertia about its centre m l^2 / 12, as cartpole.urdf states), gains from the continuous
    Riccati equation with Q = diag(1, 10, 1, 1), R = 0.1.

    Args:
        env: a ``cartpole`` env (observation: joint_pos and joint_vel of slider and pole).
    """

    def __init__(self, env: SimEnv) -> None:
        from scipy.linalg import solve_continuous_are

        big_m, m, half, g = 1.0, 0.1, 0.5, 9.8
        inertia = m * (2 * half) ** 2 / 12
        # state (x, theta, xd, thetad); force F on the cart; theta > 0 leans the tip to +x
        d = (big_m + m) * (inertia + m * half**2) - (m * half) ** 2
        a = np.zeros((4, 4))
        a[0, 2] = a[1, 3] = 1.0
        a[2, 1] = -((m * half) ** 2) * g / d
        a[3, 1] = (big_m + m) * m * g * half / d
        b = np.array([[0.0], [0.0], [(inertia + m * half**2) / d], [-m * half / d]])
        q, r = np.diag([1.0, 10.0, 1.0, 1.0]), np.array([[0.1]])
        p = solve_continuous_are(a, b, q, r)
        self.gain = (np.linalg.solve(r, b.T @ p)).ravel()  # (4,)
        self.force_scale = float(env.task.action.scale[0])
        s = _slices(env)
        self.pos, self.vel = s["joint_pos"], s["joint_vel"]

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The action for ``obs``.

        Args:
            obs: the env's observation.

        Returns:
            ``(1,)`` float32 in [-1, 1].
        """
        state = np.concatenate([obs[self.pos], obs[self.vel]]).astype(np.float64)
        force = -float(self.gain @ state)
        return np.array([np.clip(force / self.force_scale, -1.0, 1.0)], dtype=np.float32)


class KukaReachDLS:
    """Damped least squares toward the goal: ``dq = J^T (J J^T + lambda^2 I)^-1 e``, e the
    observed link-to-goal vector, J the link's position Jacobian from the controller's own
    kinematic model (a PyBullet Sim of the same URDF, finite differences of 1e-5 rad).

    Args:
        env: a ``kuka_reach`` env.
        damping: lambda (m).
        gain: the fraction of the solved step taken per control step.
    """

    def __init__(self, env: SimEnv, damping: float = 0.05, gain: float = 1.0) -> None:
        t = env.task
        spec = t.robot(t.action.robot)
        self.model = Sim("pybullet")
        self.body = self.model.load_urdf(spec.urdf, fixed_base=True)
        self.joints = [self.model.joint_index(self.body, j) for j in t.action.joints]
        link = next(c.params["link"] for c in t.success if "link" in c.params)
        self.link = self.model.link_index(self.body, link)
        self.scale = np.asarray(t.action.scale, dtype=np.float64)
        self.damping, self.gain = damping, gain
        s = _slices(env)
        self.q, self.err = s["joint_pos"], s["link_to_command"]

    def _point(self, q: np.ndarray) -> np.ndarray:
        self.model.reset_joint_state(self.body, self.joints, q)
        return np.asarray(self.model.link_state(self.body, self.link).com_position)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The action for ``obs``.

        Args:
            obs: the env's observation.

        Returns:
            ``(7,)`` float32 in [-1, 1]: joint steps over the action's scale.
        """
        q = obs[self.q].astype(np.float64)
        e = obs[self.err].astype(np.float64)
        p0 = self._point(q)
        jac = np.empty((3, len(q)))  # (3, n)
        for i in range(len(q)):
            dq = q.copy()
            dq[i] += 1e-5
            jac[:, i] = (self._point(dq) - p0) / 1e-5
        lam = self.damping**2 * np.eye(3)
        step = jac.T @ np.linalg.solve(jac @ jac.T + lam, e) * self.gain
        return np.clip(step / self.scale, -1.0, 1.0).astype(np.float32)


class DriveToGoal:
    """A unicycle law for a skid-steer base: forward speed ``v = min(k_v d, v_max) cos(e)`` and
    turn rate ``w = k_w e`` from the goal's distance d and bearing e in the base frame (the
    ``command_in_base`` term), turned into left and right wheel speeds ``(v -+ w b / 2) / r``.

    Args:
        env: a ``husky_goto`` env (wheels ordered front left, front right, rear left, rear
            right).
        radius: the wheel radius (m; husky.urdf's wheel cylinders: 0.17775).
        track: the distance between left and right wheels (m; husky.urdf's 0.5708).
        k_v: forward gain (1/s).
        k_w: turn gain (1/s).
        v_max: the speed limit (m/s).
    """

    def __init__(
        self,
        env: SimEnv,
        radius: float = 0.17775,
        track: float = 0.5708,
        k_v: float = 1.5,
        k_w: float = 3.0,
        v_max: float = 1.0,
    ) -> None:
        self.radius, self.track = radius, track
        self.k_v, self.k_w, self.v_max = k_v, k_w, v_max
        self.scale = np.asarray(env.task.action.scale, dtype=np.float64)
        self.goal = _slices(env)["command_in_base"]

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The action for ``obs``.

        Args:
            obs: the env's observation.

        Returns:
            ``(4,)`` float32 in [-1, 1]: wheel speeds over the action's scale.
        """
        gx, gy = (float(v) for v in obs[self.goal])
        bearing = float(np.arctan2(gy, gx))
        v = min(self.k_v * float(np.hypot(gx, gy)), self.v_max) * max(np.cos(bearing), 0.0)
        w = self.k_w * bearing
        left = (v - w * self.track / 2) / self.radius
        right = (v + w * self.track / 2) / self.radius
        wheels = np.array([left, right, left, right])
        return np.clip(wheels / self.scale, -1.0, 1.0).astype(np.float32)


class HoldDefault:
    """Action 0 every step: under a ``pd`` action with offset ``default`` the PD holds the default
    pose (the legged stand's reference).

    Args:
        env: an env whose action offset is ``default``.
    """

    def __init__(self, env: SimEnv) -> None:
        self.n = len(env.task.action.joints)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The action for ``obs``.

        Args:
            obs: the env's observation (not read).

        Returns:
            ``(n,)`` float32 zeros.
        """
        return np.zeros(self.n, dtype=np.float32)


class Gait:
    """An open-loop pattern for a task over an MJCF read as MuJoCo reads it: actuator ``i``'s
    control is ``amplitude[i] * sin(2 pi frequency t + phase[i])``, ``t`` the episode's time
    (``env.world.time``, 0 at each reset); the observation is not read. The ant's and the
    half cheetah's reference controllers (:data:`GAITS`).

    Args:
        env: an env whose action is ``actuator`` (one entry per actuator).
        frequency: Hz.
        amplitude: one per action entry (the action's units).
        phase: one per action entry (rad).

    Raises:
        InvalidArgumentError: ``amplitude`` or ``phase`` of another length than the action.
    """

    def __init__(
        self,
        env: SimEnv,
        frequency: float,
        amplitude: Sequence[float],
        phase: Sequence[float],
    ) -> None:
        from simbridge.exceptions import InvalidArgumentError

        n = len(env.task.action.joints)
        for name, v in (("amplitude", amplitude), ("phase", phase)):
            if len(v) != n:
                raise InvalidArgumentError(
                    name, f"expected one value per action entry ({n}), got {len(v)}"
                )
        self.env = env
        self.frequency = frequency
        self.amplitude = np.asarray(amplitude, dtype=float)
        self.phase = np.asarray(phase, dtype=float)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The action at the episode's current time.

        Args:
            obs: the env's observation (not read).

        Returns:
            ``(n,)`` float64 within [-1, 1].
        """
        w = 2.0 * np.pi * self.frequency * self.env.world.time
        return np.clip(self.amplitude * np.sin(w + self.phase), -1.0, 1.0)


GAITS: dict[str, dict[str, Any]] = {
    "ant": {
        "frequency": 0.749,
        "amplitude": [0.325, 0.344] * 4,
        "phase": [3.142, 7.039, 3.142, 7.039, 1.571, 5.468, 4.712, 8.61],
    },
    "half_cheetah": {
        "frequency": 3.0,
        "amplitude": [0.315, 0.63, 0.905, 0.242, 0.671, 0.339],
        "phase": [4.824, 5.891, 3.382, 0.056, 0.404, 2.612],
    },
}
"""A task's :class:`Gait` parameters (frequency, amplitude, phase per actuator in MuJoCo's
order), chosen by the search docs/envs.md gives."""


class AntGait(Gait):
    """The ``ant`` task's reference controller: :class:`Gait` with :data:`GAITS` ``["ant"]``
    (a class, so that ``simbridge.envs.controllers:AntGait`` is a ``module:callable`` policy).

    Args:
        env: an ``ant`` env.
    """

    def __init__(self, env: SimEnv) -> None:
        super().__init__(env, **GAITS["ant"])


class HalfCheetahGait(Gait):
    """The ``half_cheetah`` task's reference controller: :class:`Gait` with :data:`GAITS`
    ``["half_cheetah"]``.

    Args:
        env: a ``half_cheetah`` env.
    """

    def __init__(self, env: SimEnv) -> None:
        super().__init__(env, **GAITS["half_cheetah"])


CONTROLLERS: dict[str, Any] = {
    "cartpole": CartPoleLQR,
    "kuka_reach": KukaReachDLS,
    "husky_goto": DriveToGoal,
    "a1_stand": HoldDefault,
    "ant": AntGait,
    "half_cheetah": HalfCheetahGait,
}
"""Shipped task name -> its reference controller's class."""


def reference_controller(env: SimEnv) -> Any:
    """The reference controller of a shipped task, made for ``env``.

    Args:
        env: an env of a shipped task.

    Returns:
        A callable observation -> action.

    Raises:
        KeyError: a task with no reference controller (the message lists those that have one).
    """
    name = env.task.name
    if name not in CONTROLLERS:
        raise KeyError(
            f"task {name!r} has no reference controller; those that do: {sorted(CONTROLLERS)}"
        )
    return CONTROLLERS[name](env)
