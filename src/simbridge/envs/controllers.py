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
    "GAITS",
    "AntGait",
    "Gait",
    "HalfCheetahGait",
    "CartPoleLQR",
    "DriveToGoal",
    "HoldDefault",
    "KukaReachDLS",
    "Trot",
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


def _leg_ik(x: np.ndarray, z: np.ndarray, l1: float, l2: float) -> tuple[np.ndarray, np.ndarray]:
    """A two-link leg's inverse kinematics in its sagittal plane, knee bent backward.

    The foot, from the thigh joint, is ``x = -l1 sin q1 - l2 sin(q1 + q2)``,
    ``z = -l1 cos q1 - l2 cos(q1 + q2)`` (both joints about +y, the links along -z at 0, as
    the A1's and legged_gym's legs are).

    Args:
        x: the feet's forward offsets (m), ``(k,)``.
        z: their heights below the thigh joint (m, negative), ``(k,)``.
        l1: the thigh's length (m).
        l2: the calf's length (m).

    Returns:
        ``(q1, q2)``: thigh and calf angles (rad), ``(k,)`` each; q2 <= 0. A foot out of reach
        is pulled onto the reachable annulus.
    """
    r2 = x * x + z * z
    c2 = np.clip((r2 - l1 * l1 - l2 * l2) / (2 * l1 * l2), -1.0, 1.0)
    q2 = -np.arccos(c2)
    q1 = np.arctan2(-x, -z) - np.arctan2(l2 * np.sin(q2), l1 + l2 * np.cos(q2))
    return q1, q2


class Trot:
    """A scripted trot for the A1 under legged RL's soft PD (``a1_walk``): each foot follows a
    periodic path, turned into thigh and calf targets by the leg's analytic inverse kinematics
    (:func:`_leg_ik`) and into a hip target by the foot's sideways offset.

    The clock is the observation's ``gait_phase`` (sin, cos), so the trot runs in step with the
    task's period. Diagonal pairs move together (FR with RL, FL with RR, half a period apart);
    each foot is on the ground for half the period and in the air for the other half, on a
    raised cosine of height ``step_height``. Under kp 20 the joints lag their targets and sag
    under the body's weight, so the path is not enough on its own; what it needed, each term
    measured on all three engines (docs/envs.md):

    - Foot placement (Raibert's): a foot lands at ``v T / 4 + k_v (v - v_cmd)`` ahead of its
      default place, ``v`` the observed base velocity; sideways the same with ``k_y``.
    - The stance foot sweeps back by the stride ``gain (v_cmd + bias + k_i e) T / 2``, ``e``
      the integral of the speed error since the reset (without it the trot settles 0.1 m/s
      below the command on every engine).
    - Heading: the yaw rate is integrated since the reset; the rate wanted,
      ``yaw_cmd - k_head heading``, lengthens one side's stride and shortens the other's by
      ``k_yaw`` per rad/s of error. Sideways drift in the base frame is steered back by
      ``k_lat``.
    - Load: a stance foot's targets are moved by the torques that carry half the robot's
      weight, ``J^T (0, -load m g / 2) / kp``, faded in and out by ``sin(pi s)^smooth`` over
      the stance; ``k_att`` shortens the legs on the body's high side (projected gravity).
    - Timing: the path runs ``lead`` periods ahead of the clock (the PD's lag); the feet's
      neutral places are ``shift`` behind the default pose and ``push`` lower in stance.

    It keeps three integrals (speed error, heading, sideways travel), reset when it sees an
    episode's first observation (phase exactly (0, 1) and a last action of zeros): a policy
    with memory, as a recurrent one is. It reads the A1's hip places and leg lengths.

    Args:
        env: an env whose action is legged RL's PD (offset ``default``) on twelve joints
            ordered hip, thigh, calf for FR, FL, RR, RL, and whose observation holds
            ``gait_phase``, ``commands`` (vx, vy, yaw rate), ``base_lin_vel``,
            ``base_ang_vel``, ``projected_gravity`` and ``last_action``.
        step_height: the swing foot's lift (m).
        push: how much lower than the default the stance foot is placed (m).
        k_v: forward foot placement per m/s of speed error (s).
        k_y: sideways foot placement per m/s of sideways speed (s).
        k_yaw: stride speed difference between the sides per rad/s of yaw-rate error (m/rad).
        k_att: leg shortening per unit of projected gravity's x, y times the hip's place.
        shift: the feet's neutral places behind the default (m).
        smooth: the exponent of the stance load's ``sin(pi s)`` fade.
        gain: stride over the commanded one.
        k_head: yaw rate wanted per rad of heading error (1/s).
        lead: the path's lead over the clock (periods).
        load: the fraction of half the weight each stance foot's targets carry.
        bias: added to the commanded speed (m/s).
        k_i: stride speed per m of integrated speed error (1/s).
        k_lat: sideways speed wanted per m of sideways travel (1/s).
        mass: the robot's mass (kg; a1.urdf's links sum to 12.458).
        thigh: the thigh's length (m; a1.urdf's 0.2).
        calf: the calf's length (m; a1.urdf's 0.2).
    """

    HIPS = np.array([[0.183, -0.132], [0.183, 0.132], [-0.183, -0.132], [-0.183, 0.132]])
    """(4, 2): the thigh joints' x, y in the base frame (m; a1.urdf), FR, FL, RR, RL."""

    def __init__(
        self,
        env: SimEnv,
        *,
        step_height: float = 0.0698,
        push: float = 0.0215,
        k_v: float = 0.0926,
        k_y: float = -0.1706,
        k_yaw: float = 0.0781,
        k_att: float = 1.3457,
        shift: float = 0.005,
        smooth: float = 0.5341,
        gain: float = 1.3232,
        k_head: float = 2.0,
        lead: float = 0.1766,
        load: float = 0.1151,
        bias: float = 0.1,
        k_i: float = 1.5,
        k_lat: float = 0.0,
        mass: float = 12.458,
        thigh: float = 0.2,
        calf: float = 0.2,
    ) -> None:
        t = env.task
        self.scale = np.broadcast_to(np.asarray(t.action.scale, float), (12,)).copy()
        pose = t.robot(t.action.robot).joint_positions
        self.default = np.array([pose.get(j, 0.0) for j in t.action.joints])  # (12,)
        self.l1, self.l2 = thigh, calf
        q1, q2 = self.default[1::3], self.default[2::3]  # (4,) thigh and calf, FR FL RR RL
        self.x0 = -thigh * np.sin(q1) - calf * np.sin(q1 + q2)  # the feet's default places
        self.z0 = -thigh * np.cos(q1) - calf * np.cos(q1 + q2)
        self.offset = np.array([0.0, 0.5, 0.5, 0.0])  # FR, FL, RR, RL: diagonal pairs
        self.side = np.array([-1.0, 1.0, -1.0, 1.0])  # right legs -1
        self.step_height, self.push, self.k_v, self.k_y = step_height, push, k_v, k_y
        self.k_yaw, self.k_att, self.shift, self.smooth = k_yaw, k_att, shift, smooth
        self.gain, self.k_head, self.lead, self.bias = gain, k_head, lead, bias
        self.k_i, self.k_lat = k_i, k_lat
        self.weight = load * mass * 9.81 / 2  # (N) on each stance foot of a diagonal pair
        kp = np.broadcast_to(np.asarray(t.action.kp, float), (12,))
        self.kp1, self.kp2 = kp[1::3], kp[2::3]
        self.dt = t.control_dt
        self.slow = 0.0  # (m) the command's lead over the observed forward travel
        self.heading = 0.0  # (rad) the observed yaw rate's integral
        self.drift = 0.0  # (m) the observed sideways speed's integral (base frame)
        obs = env.contract()["observation"]
        terms = {term["name"]: term for term in obs["terms"]}
        self.period = float(terms["gait_phase"]["params"].get("period", 1.0))
        s = _slices(env)
        self.phase, self.cmd, self.grav = s["gait_phase"], s["commands"], s["projected_gravity"]
        self.lin, self.ang, self.last = s["base_lin_vel"], s["base_ang_vel"], s["last_action"]
        self.cmd_scale = np.broadcast_to(np.asarray(terms["commands"]["scale"], float), (3,))
        self.lin_scale = np.broadcast_to(np.asarray(terms["base_lin_vel"]["scale"], float), (3,))
        self.ang_scale = np.broadcast_to(np.asarray(terms["base_ang_vel"]["scale"], float), (3,))

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """The action for ``obs``.

        Args:
            obs: the env's observation.

        Returns:
            ``(12,)`` float32: joint offsets from the default pose over the action's scale.
        """
        sin, cos = (float(v) for v in obs[self.phase])
        cmd = obs[self.cmd].astype(np.float64) / self.cmd_scale  # vx, vy, yaw rate
        v = obs[self.lin].astype(np.float64) / self.lin_scale  # (3,) m/s, base frame
        w = obs[self.ang].astype(np.float64) / self.ang_scale  # (3,) rad/s, base frame
        if cos == 1.0 and sin == 0.0 and not obs[self.last].any():  # an episode's start
            self.slow = self.heading = self.drift = 0.0
        self.slow += (cmd[0] - v[0]) * self.dt
        self.heading += w[2] * self.dt
        self.drift += v[1] * self.dt
        rate = cmd[2] - self.k_head * self.heading
        turn = self.side * self.k_yaw * (rate - w[2])  # (4,) right legs faster to turn left
        speed = cmd[0] + self.bias + self.k_i * self.slow - turn  # (4,) m/s
        stride = self.gain * speed * self.period / 2  # (4,) the ground's travel under a foot
        land = v[0] * self.period / 4 + self.k_v * (v[0] - cmd[0])
        want_y = cmd[1] - self.k_lat * self.drift  # (m/s) back toward the straight line
        sweep = want_y * self.period / 2
        land_y = sweep / 2 + v[1] * self.period / 4 + self.k_y * (v[1] - want_y)
        phase = (np.arctan2(sin, cos) / (2 * np.pi) + self.lead) % 1.0
        p = (phase + self.offset) % 1.0  # (4,) each leg's phase: stance, then swing
        stance = p < 0.5
        s = np.where(stance, p / 0.5, (p - 0.5) / 0.5)  # (4,) 0 -> 1 within each half
        rise = (1 - np.cos(np.pi * s)) / 2
        x = np.where(stance, land - stride * s, land - stride + stride * rise)
        y = np.where(stance, land_y - sweep * s, land_y - sweep + sweep * rise)
        z = np.where(stance, -self.push, self.step_height * np.sin(np.pi * s))
        g = obs[self.grav].astype(np.float64)
        z = z - self.k_att * (self.HIPS @ g[:2])  # shorten the legs on the body's high side
        fx, fz = self.x0 - self.shift + x, self.z0 + z
        q1, q2 = _leg_ik(fx, fz, self.l1, self.l2)
        # a stance foot carries its share of the weight: the PD's targets moved by the
        # torques J^T (0, -W) over kp, so that the joints hold their place under the load
        f = np.where(stance, self.weight * np.sin(np.pi * s) ** self.smooth, 0.0)  # (4,) N
        q1, q2 = q1 + fx * f / self.kp1, q2 - self.l2 * np.sin(q1 + q2) * f / self.kp2
        q = self.default.copy()
        q[0::3] += y / -fz  # the hip turns the foot sideways by y
        q[1::3], q[2::3] = q1, q2
        return ((q - self.default) / self.scale).astype(np.float32)


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
    "a1_walk": Trot,
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
