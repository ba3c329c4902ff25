"""`Sim` on PhysX 5 through SAPIEN 3: PyBullet's joint table, frames and command semantics.

One SAPIEN scene with a CPU PhysX system holds the world; each robot is one articulation built
from simbridge's own reading of its file (model.py), or one static actor when nothing of it
moves. A step sets what PyBullet's motors ask for as PhysX joint drives (commands.py), steps the
scene once and clears the torques of that step.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import sapien
from sapien import physx

from simbridge.backend import Backend
from simbridge.exceptions import (
    SimBusyError,
    SimulationDivergedError,
)
from simbridge.model.build_plan import build_plan
from simbridge.model.joint_table import joint_table
from simbridge.model.load_options import LoadOptions
from simbridge.model.urdf import UrdfModel
from simbridge.profiles import Profile
from simbridge.types import Quat, Vec3

from .. import locking
from ..locking import exclusive, wait_for_lock
from .ball import BallJoints, default_ball_motor
from .combine import product_combine_available
from .commands import DRIVE_DAMPING, MotorCommands
from .contacts import ContactReads
from .limits import LimitRows, limit_rows
from .model import build_robot
from .reads import StateReads
from .robots import Robot, default_motors, movable_joints
from .window import Window
from .world import Snapshots

if TYPE_CHECKING:
    from simbridge.model.mjcf_native import NativeMjcf
    from simbridge.model.scene import SceneBody

__all__ = ["PhysxBackend"]

_log = logging.getLogger("simbridge.physx")

_BUSY = "this Sim is stepping in another thread; a Sim takes one call at a time"
# "periodic" divergence check: the state is looked at every this many steps (and at every read)
CHECK_EVERY = 8


# engine settings that are SAPIEN scene-config flags of the same name (backends/settings_physx.py)
_SCENE_FLAGS = ("enable_pcm", "enable_friction_every_iteration", "enable_enhanced_determinism")


class PhysxBackend(
    StateReads, MotorCommands, BallJoints, ContactReads, LimitRows, Snapshots, Backend
):
    """`Sim` on PhysX 5 (SAPIEN 3.0.3, CPU).

    Args:
        profile: The physics settings to reproduce (time step, gravity, solver, defaults).
        gui: Whether to open SAPIEN's window in a process of its own (window.py).

    Raises:
        BackendUnsupportedError: For a profile setting PhysX cannot reproduce
            (``Backend.refuse_unsupported``), or ``gui`` where SAPIEN finds no Vulkan device.
        DisplayError: With ``gui`` where the window cannot open.
    """

    name = "physx"
    semantics = ("pybullet", "mujoco")
    # PhysX keeps poses and velocities in float32 (DEPARTURES["precision"]): readable before an
    # engine is made, for a perturbation this engine can represent
    state_dtype = "float32"

    NATIVE_DEFAULTS = {
        "gravity": (0.0, 0.0, -9.81),
        "timestep": 0.01,
        "solver": "TGS, 10 position and 1 velocity iterations (here: PGS, the profile's count)",
        "joint_brake": "none",
        "joint_friction": 0.05,
        "max_link_angular_velocity": 50.0,
        "max_link_linear_velocity": 10.0,
        "max_joint_velocity": 100.0,
        "max_depenetration_velocity": 1e32,
        "friction_combine": "average (here: the product, combine.py)",
        "restitution_combine": "average",
        "contact_offset": 0.01,
        "rest_offset": 0.0,
        "self_collision": "yes, but parent and child",
        "state": "float32",
    }

    def __init__(self, profile: Profile, gui: bool = False) -> None:
        super().__init__(profile, gui)
        self.refuse_unsupported()
        # the window (window.py): its own process; None headless, where nothing of it is made
        self._window: Window | None = Window(self.name) if gui else None
        self._dt = profile.timestep
        self._robots: dict[int, Robot] = {}
        self._stepping = threading.RLock()
        self._in_step = False
        self._closed = False
        self._next_id = 0
        self._free_ids: list[int] = []
        self._steps = 0
        self._diverged: SimulationDivergedError | None = None
        self._every_step = False
        self._new_world()

    def _new_world(self) -> None:
        p = self.profile
        cfg = physx.PhysxSceneConfig()
        cfg.gravity = np.asarray(p.gravity, dtype=np.float32)
        cfg.bounce_threshold = 2.0
        # PGS, PyBullet's kind of solver: under TGS (PhysX's default) r2d2's wheels, turning it
        # on the spot at 100 rad/s, kick to 1150 rad/s for a step (PGS: never past the target;
        # PyBullet's wheels drop as low as 10 rad/s for a step too, as PGS's do)
        cfg.enable_tgs = False
        # the engine settings the profile sets (backends/settings_physx.py); the shapes' and the
        # articulations' ones: model.build_robot
        settings = p.engine(self.name)
        if "solver" in settings:
            cfg.enable_tgs = settings["solver"] == "TGS"
        if "bounce_threshold" in settings:
            cfg.bounce_threshold = settings["bounce_threshold"]
        for flag in _SCENE_FLAGS:
            if flag in settings:
                setattr(cfg, flag, settings[flag])
        physx.set_scene_config(cfg)
        self._system = physx.PhysxCpuSystem()
        self._scene = sapien.Scene([self._system])
        self._scene.timestep = p.timestep
        self._diverged = None
        self._generation = getattr(self, "_generation", 0) + 1  # a new world: old snapshots void
        self._contacts_cache: list[Any] | None = None
        # since a remove, the last step's points less the removed bodies' (contacts.py)
        self._contacts_kept: list[Any] | None = None
        self._restored: list[Robot] = []  # robots whose link velocities a restore put back
        self._active: list[Robot] = []  # robots that need work before or after a step
        self._clamped: list[Any] = []  # articulations whose joint speeds the profile clamps

    @property
    def time(self) -> float:
        return self._steps * self._dt

    def mjcf_world(
        self, native: NativeMjcf, gravity: Vec3 | None, timestep: float | None
    ) -> Backend:
        """See Backend.mjcf_world.

        PhysX: :class:`~.native.NativePhysx`, the compiled model built as articulations,
        MuJoCo's armature and damping on the joints, its actuator and spring forces as joint
        forces.

        With ``gui`` this world's window is handed over: it draws the model from then on
        (this world, closed next, no longer owns it); if the model is refused, the window
        stays this world's and draws it again.

        Raises:
            MjcfFeatureUnsupportedError: A feature only MuJoCo simulates.
        """
        from .native import NativePhysx

        window, self._window = self._window, None
        try:
            return NativePhysx(self.profile, native, gravity, timestep, window=window)
        except BaseException:
            self._window = window
            self._show()
            raise

    # ---------------------------------------------------------------- world

    def _check_idle(self) -> None:
        if self._in_step:
            raise SimBusyError(_BUSY)

    @exclusive
    def load(
        self,
        model: UrdfModel,
        base_position: Vec3,
        base_orientation: Quat,
        fixed_base: bool,
        options: LoadOptions,
    ) -> int:
        """See Backend.load.

        PhysX: one articulation per robot (a static actor for a body with no movable joint), built
        from the build plan; a spherical joint as three revolutes (ball.py).
        """
        self._check_idle()
        body = self._free_ids[-1] if self._free_ids else self._next_id
        plan = build_plan(
            model,
            self.profile,
            options,
            fixed_base=fixed_base,
            base_position=base_position,
            base_orientation=base_orientation,
        )
        built = build_robot(
            self._scene,
            plan,
            self.profile.solver_iterations,
            body + 1,
            self.profile.engine(self.name),
        )
        built.plan = plan
        try:
            fixed = plan.fixed_base
            table = joint_table(model, fixed_base, built.inertials)
            movable = movable_joints(table)
            robot = self._robot(body, model, built, table, fixed, movable)
            robot.motors = default_motors(model, movable, self.profile)
            robot.drive_force = [float("nan")] * len(movable)
            robot.moving_links = [
                comp for comp, lp in zip(built.links, plan.links, strict=False) if not lp.static
            ]
            robot.moving_rows = np.array(  # their rows in built.links
                [i for i, lp in enumerate(plan.links[: len(built.links)]) if not lp.static],
                dtype=np.intp,
            )
            self._configure(robot)
            limit_rows(robot, self.profile.engine(self.name).get("limit_rule", "hard"))
        except BaseException:
            for entity in built.entities:
                self._scene.remove_entity(entity)
            raise
        robot.unlimited_spherical = [
            lp.joint.name
            for lp in plan.links
            if lp.joint is not None and lp.joint.spherical_limit is not None
        ]
        if robot.unlimited_spherical:
            _log.warning(
                "%s: spherical joints %s have PyBullet's swing/twist limit (<limit lower upper "
                "twist effort> all > 0), which the PhysX backend does not enforce: listed in "
                "manifest()['departures']",
                model.source.display_name,
                robot.unlimited_spherical,
            )
        self._robots[body] = robot
        self._generation += 1
        if self._free_ids:
            self._free_ids.pop()
        else:
            self._next_id += 1
        self._check_limits(robot)  # a joint whose range leaves out 0 starts past its limit
        self._refresh_active()
        self._show()
        return body

    def _show(self) -> None:
        """The window's world anew (after a load, a removal or a reset)."""
        if self._window is not None:
            self._window.show(self._robots.values())

    def _robot(
        self,
        body: int,
        model: UrdfModel,
        built: Any,
        table: list[Any],
        fixed: bool,
        movable: list[int],
    ) -> Robot:
        n = len(model.joints)
        dof = np.full(n, -1, dtype=np.intp)
        joints: list[Any] = [None] * n
        ndof = 0
        if not built.static:
            art = built.articulation
            start = 0
            by_name = {}
            for j in art.get_active_joints():
                by_name[j.name] = (start, j)
                start += j.dof
            ndof = start
            ball_dofs: dict[int, tuple[int, int, int]] = {}
            for k, uj in enumerate(model.joints):
                joints[k] = built.links[k + 1].joint
                if uj.type == "spherical":
                    d3 = tuple(by_name[f"{uj.name}#{axis}"][0] for axis in range(3))
                    ball_dofs[k] = (d3[0], d3[1], d3[2])
                    dof[k] = d3[0]
                elif uj.type != "fixed":
                    dof[k] = by_name[uj.name][0]
        robot = Robot(body, model, built, table, fixed, movable, dof, ndof, joints)
        if not built.static:
            robot.ball_dofs = ball_dofs
            robot.dof_joint = {start: j for start, j in by_name.values()}
            robot.balls = {k: default_ball_motor(self.profile) for k in ball_dofs}
        robot.slot = {j: s for s, j in enumerate(movable)}
        return robot

    @exclusive
    def load_scene(self, bodies: Sequence[SceneBody], options: LoadOptions) -> list[int]:
        """See Backend.load_scene.

        PhysX: every body of the file under one hold of the Sim's lock.
        """
        return super().load_scene(bodies, options)

    @exclusive
    def remove(self, body: int) -> None:
        """See Backend.remove. PhysX: the body's entities leave the scene."""
        self._check_idle()
        self._keep_contacts_but(body)  # the scene's report would name removed components
        robot = self._robots.pop(body)
        for entity in robot.built.entities:
            self._scene.remove_entity(entity)
        self._free_ids.append(body)
        self._generation += 1
        self._refresh_active()
        self._show()

    @exclusive
    def reset(self) -> None:
        """See Backend.reset. PhysX: a new, empty scene."""
        self._check_idle()
        self._robots.clear()
        self._next_id = 0
        self._free_ids.clear()
        self._steps = 0
        self._new_world()
        self._show()

    reading = locking.reading

    def set_divergence_check(self, every_step: bool) -> None:
        """See Backend.set_divergence_check.

        PhysX: with True, the world is checked after every step.
        """
        self._every_step = every_step

    # ---------------------------------------------------------------- stepping

    def step(self, n: int) -> None:
        """See Backend.step.

        PhysX: the motors, PyBullet's limit rows and link damping are applied around each
        ``system.step()``.
        """
        lock = self._stepping
        if not lock.acquire(False):
            wait_for_lock(self)
        if self._in_step:
            lock.release()
            raise SimBusyError(_BUSY)
        self._in_step = True
        try:
            if self._diverged is not None:
                raise self._diverged
            system = self._system
            active = self._active
            every = self._every_step
            cap = self.profile.max_joint_velocity
            window = self._window
            for _ in range(n):
                for robot in active:
                    if robot.damping_only:
                        robot.damper()  # type: ignore[misc]  # set with damping_only
                    else:
                        self._before_step(robot)
                system.step()
                self._steps += 1
                if self._restored:  # PhysX's own link velocities from here on
                    self._forget_restored()
                for robot in active:
                    if robot.qf_set or robot.pending:  # else _after_step has nothing to do
                        self._after_step(robot)
                    if robot.held:  # a joint past its limit: PyBullet's limit row (limits.py)
                        self._limit_rows_after(robot)
                if cap is not None:  # PyBullet's clamp of the joint speeds (_clamp_speeds)
                    for art in self._clamped:
                        v = art.qvel
                        speeds = v.tolist()
                        if max(map(abs, speeds)) > cap:
                            self._clamp_speeds(art, v, speeds, cap)
                if every or self._steps % CHECK_EVERY == 0:
                    self._check_world()
                if window is not None:
                    window.sync()
            if n > 0:
                self._contacts_cache = self._contacts_kept = None
        finally:
            self._in_step = False
            lock.release()

    def _forget_restored(self) -> None:
        """The link velocities a restore put back end at a step or a write of the state."""
        for robot in self._restored:
            robot.restored_velocities = None
        self._restored = []

    def _check_world(self) -> None:
        """SimulationDivergedError when any robot's state is not finite."""
        for robot in self._robots.values():
            if robot.static:
                continue
            art = robot.built.articulation
            root = robot.built.links[0]
            # float32 values summed in float64 cannot overflow: the sum is finite exactly when
            # every value is (an inf or a NaN carries through), and costs a fraction of numpy's
            # isfinite and all on each of these short arrays
            total = (
                sum(art.qpos.tolist())
                + sum(art.qvel.tolist())
                + sum(root.entity_pose.p.tolist())
                + sum(root.linear_velocity.tolist())
            )
            if not math.isfinite(total):
                self._diverged = SimulationDivergedError(
                    self.name, self.time, f"body {robot.id} state"
                )
                raise self._diverged

    @exclusive
    def close(self) -> None:
        """See Backend.close. PhysX: the window closes; the scene and system are released."""
        if self._closed:
            return
        self._check_idle()
        self._closed = True
        if self._window is not None:
            self._window.close()
            self._window = None
        self._robots.clear()
        self._active = []
        self._scene = None
        self._system = None

    # ---------------------------------------------------------------- description

    DEPARTURES = {
        "precision": (
            "PhysX keeps the state in float32 (spacing 1.2e-7 m at 1 m, 6e-8 rad/s near 1 rad/s): "
            "reads are float32 values as float64"
        ),
        "contact": (
            "PhysX's contact (PGS solver, contacts made within the shapes' 1 cm contact "
            "offsets, two shapes at rest 1 mm apart, twice the 0.5 mm rest offset) instead of "
            "PyBullet's sequential impulse with a 1 mm collision margin"
        ),
        "rolling/spinning friction": "PhysX has none: <contact> rolling and spinning friction "
        "are reported, not applied",
        "link damping": (
            "PhysX's link damping v -= k v dt per step (its law) with the profile's k; "
            "PyBullet's adds the quadratic term k |v| v"
        ),
        "speed clamp": (
            "joint speeds clamped after each step to the profile's max_joint_velocity (100 rad/s "
            "or m/s under 'pybullet'), each joint's speed on its own, as PyBullet does; PhysX's "
            "joint max velocity is set to the same cap, which bounds its drives inside the "
            "solver too. A free base's speed is clamped by its link's max linear and angular "
            "speed (the norm of each, inside PhysX's solver; PyBullet clamps each coordinate "
            "after the step)"
        ),
        "motors": (
            "PyBullet's velocity motor as a PhysX drive (stiffness 0, damping "
            f"{DRIVE_DAMPING:g} N·m·s/rad or N·s/m, force limit max_force); its position law "
            "as a velocity target "
            "kp (q* - q) / dt + (1 - kd) v set before each step (v: the velocity at the start of "
            "the step, PyBullet's the velocity after the smooth forces)"
        ),
        "coupled drives": (
            "PhysX solves an articulation's drives one joint at a time down the chain: on a long "
            "chain of light links they converge over many steps (a 16-link arm of 0.1 kg links "
            "at PyBullet's inertia rule, velocity motors at 0.5 rad/s: 0.19 .. 0.5 after 2 "
            "steps; raw SAPIEN the same; bench/physx_chain_drives.py)"
        ),
        "applied torques": (
            "a drive's force is not reported by PhysX: joint_states' applied torque is the "
            "joint's incoming force along its axis less the joint forces the step was given "
            "(a torque command, URDF damping) (kuka joint 0 held at max_force 1000 N m: reads "
            "1000.2; under a 50 N m torque command alone 1.4e-4 to 1.3e-3 for PyBullet's 0)"
        ),
        "snapshot": (
            "get_state/set_state put back positions and velocities (float32; exact=True: "
            "PhysX's pack/unpack), the motors, and every link's velocities as PhysX reported "
            "them: unpack recomputes those from the joint velocities (0.25 rad/s away from the "
            "ones its step left on a swinging kuka_iiwa), and they are the input of PyBullet's "
            "link damping law. With a fixed base and no contacts the next steps are the same "
            "bits (conformance test_state.py; before the link velocities were kept: 5.96e-8 rad "
            "10 steps after set_state on kuka_iiwa swinging from rest, brake off). Not put back, "
            "as SAPIEN 3.0.3 sets neither: (1) a floating base's link poses, which PhysX's step "
            "carries forward in float32 and unpack, as any write of joint positions or of the "
            "root pose (a teleport, even of the same values), derives afresh from the root pose "
            "and the joint positions, 1.5e-8 m away: r2d2 tumbling in the air is 6.0e-8 off 10 "
            "steps after set_state, humanoid.urdf 1.2e-6 (raw SAPIEN on a 7-link chain: 2.1e-6 "
            "rad; bench/physx_snapshot.py); (2) contacts: such a write makes PhysX start the "
            "next step's contacts afresh. Measured on r2d2 driving at 2 rad/s: the step after a "
            "write of the unchanged positions differs from the uninterrupted one by 2.3 rad/s on "
            "a wheel (velocities alone: 0); on conformance test_state's r2d2 drive (wheels at "
            "-5 rad/s, max_force 10) the largest one-step difference after set_state is 4.52 "
            "(same sim, portable state: 3.41; from another sim: 2.28); not a bitwise "
            "continuation where a floating base moves or anything touches"
        ),
        "contact friction": (
            "PhysX reports no friction impulse per contact point (SAPIEN 3.0.3): "
            "contact_points' friction fields are 0"
        ),
        "cylinder": "PyBullet's 32-gon prism hull, as PyBullet collides with it",
        "meshes": (
            "every collision mesh is the convex hull of its vertices (PyBullet: one hull per "
            ".obj object)"
        ),
        "joint axis": "a non-unit <axis> is normalised (PyBullet moves |axis| rad per unit q)",
        "joint limits": (
            "PhysX's hard joint limits; a joint past its limit (after a reset, a restore or "
            "the load) gets PyBullet's limit row instead until it is back in range (stop "
            "outward motion, within 0.04 of the limit push back at 0.2 depth/dt: limits.py). "
            "slider.urdf (limits +-0.4 m) reset at or past a limit, 60 steps: within 3.0e-7 m "
            "and 4.8e-7 m/s of PyBullet, 1.7e-6 m where the float32 position slides at 0.5 m/s "
            "(PhysX's own limit: 1.10 m, 57.6 m/s off); a hinge loaded outside its range under "
            "gravity 2.1e-7 rad; a free two-hinge chain whose elbow is reset 0.039 rad past "
            "its limit 2.1e-5 rad (the row's impulse moves a fixed-base chain through the "
            "inverse mass matrix; on a floating base only the held joint moves). A joint "
            "arriving at its limit from inside is stopped on it by PhysX; "
            "PyBullet lets it pass by up to one step's travel and pushes it back (slider at "
            "1 m/s: 0.4042 m, then back in at -0.2 m/s; 2.5e-2 m apart after 60 steps)"
        ),
        "spherical joints": (
            "three revolute joints about the child's inertial axes through two 1e-6 kg links "
            "(SAPIEN 3.0.3 has no spherical joint; ball.py): gimbal lock at the middle angle "
            "+-pi/2; PyBullet's motor per axis of the child's frame becomes the three drives' "
            "targets (their axes are the child's only at the zero pose); no motor torque is "
            "reported; PyBullet's swing/twist limit is not enforced"
        ),
        "self collision": (
            "the plan's excluded pairs through SAPIEN's ignore bits (exact up to 32 pairs per "
            "body); PhysX never lets a joint's parent and child touch, so 'include_parent' "
            "misses those pairs (and, measured on the conformance tree, base and link 2)"
        ),
    }

    PYBULLET_LIMITS = (
        "limit_rule 'pybullet', PyBullet's rule: no limit until a step starts at or past it "
        "(PhysX's own limits moved 10 out of the range), so a joint passes by up to one step's "
        "travel, then PyBullet's row stands in (stop outward motion, within 0.04 push back at "
        "0.2 depth/dt: limits.py); a joint travelling more than 10 past its limit in one step "
        "is stopped there. The slider at 1 m/s toward its 0.4 m limit within 5.9e-7 m of "
        "PyBullet over 240 steps, a KUKA falling into its joint-2 limit within 5.8e-3 rad "
        "(bench/limit_rule.py)"
    )

    def manifest(self) -> dict[str, Any]:
        """See Backend.manifest.

        PhysX: the limit rule, friction combine, window and each body's departures.
        """
        departures: dict[str, str] = dict(self.DEPARTURES)
        if self.profile.engine(self.name).get("limit_rule") == "pybullet":
            departures["joint limits"] = self.PYBULLET_LIMITS
        if not product_combine_available():
            departures["friction combine"] = (
                "PhysX combines two materials' friction and restitution as their average: this "
                "SAPIEN build's setFrictionCombineMode could not be reached (combine.py); "
                "PyBullet takes the product: a pair of 0.5 and 1.0 (r2d2 on plane.urdf) slides "
                "at 0.75 here, 0.5 on PyBullet"
            )
        if self._window is not None:
            departures["window"] = (
                "SAPIEN's window in its own process, flat-shaded (one light on the camera, no "
                "shadows or textures), the camera following the robots, turned by a drag, no "
                "zoom: SAPIEN's own lit shaders took 22-34 s to their first frame on Mesa's "
                "lavapipe, these 0.3-0.7 s"
            )
        for r in self._robots.values():
            if r.built.bounded_links:
                departures[f"body {r.id} mass bound"] = (
                    f"links {r.built.bounded_links} move but have zero mass or inertia: raised "
                    "to 1e-06 kg / 1e-10 kg m^2 (PhysX refuses zero)"
                )
            if r.unlimited_spherical:
                departures[f"body {r.id} spherical joint limits"] = (
                    f"{r.unlimited_spherical}: PyBullet's btMultiBodySphericalJointLimit (swing "
                    "about x within <limit lower>, about y within upper, twist within twist) is "
                    "not enforced; the joint moves past it (spherical_joint_limit.urdf's neck "
                    "pushed 5 N m for one step: 2.01 rad where PyBullet stops at 0.2)"
                )
            if r.built.skipped_shapes:
                departures[f"body {r.id} shapes left out"] = (
                    f"{r.built.skipped_shapes}: meshes PhysX cannot make a hull of"
                )
        return {
            "backend": self.name,
            "engine": "PhysX 5 (reduced-coordinate articulations, PGS) through SAPIEN",
            "engine_version": f"SAPIEN {sapien.__version__}",
            "native_defaults": self.NATIVE_DEFAULTS,
            "departures": departures,
        }
