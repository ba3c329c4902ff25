"""PyBullet's engine settings: ``setPhysicsEngineParameter`` entries users tune.

Imports no engine (read when a profile or a scenario is checked). The defaults are the values
PyBullet's server starts a world with (PhysicsServerCommandProcessor, btContactSolverInfo),
held by tests/interface/test_engine_settings.py: each one given explicitly leaves a run bit for bit
as it is with none given. The backend sends only the settings a profile sets.
Left out: ``contactBreakingThreshold`` (a process-wide global in Bullet: it would reach every
other PyBullet world of the process), ``numSolverIterations`` (the profile's
``solver_iterations``), ``fixedTimeStep`` (the profile's ``timestep``).
"""

from __future__ import annotations

from simbridge.engine_settings import Setting

SETTINGS = (
    Setting(
        "erp",
        "float",
        0.2,
        "share of a joint (non-contact) constraint's error corrected per step",
        low=0.0,
        high=1.0,
    ),
    Setting(
        "contactERP",
        "float",
        0.08,
        "share of a contact's penetration corrected per step (a stiffer contact when higher)",
        low=0.0,
        high=1.0,
        toward="mujoco.solref",
    ),
    Setting(
        "frictionERP",
        "float",
        0.2,
        "share of a friction constraint's drift corrected per step",
        low=0.0,
        high=1.0,
    ),
    Setting(
        "globalCFM",
        "float",
        0.0,
        "constraint force mixing added to every row (softens every constraint)",
        low=0.0,
        toward="mujoco.solimp",
    ),
    Setting(
        "useSplitImpulse",
        "bool",
        True,
        "push penetrations out by a separate position correction, adding no velocity "
        "(measured: no change to a URDF body's contacts, which Bullet solves as a multibody)",
    ),
    Setting(
        "splitImpulsePenetrationThreshold",
        "float",
        -0.04,
        "penetration (negative distance) past which split impulse stops and the contact's "
        "velocity takes the correction (see useSplitImpulse)",
        unit="m",
        high=0.0,
        toward="physx.max_depenetration_velocity",
    ),
    Setting(
        "contactSlop",
        "float",
        1e-5,
        "penetration left uncorrected (the contact's allowed slop)",
        unit="m",
        low=0.0,
        toward="mujoco.margin",
    ),
    Setting(
        "restitutionVelocityThreshold",
        "float",
        0.2,
        "approach speed under which a contact does not bounce",
        unit="m/s",
        low=0.0,
        toward="physx.bounce_threshold",
    ),
    Setting(
        "enableConeFriction",
        "bool",
        True,
        "friction limited by a cone (true) or by the two-direction pyramid (false)",
        toward="mujoco.cone",
    ),
    Setting(
        "numSubSteps",
        "int",
        0,
        "each step split into this many sub-steps (0: none)",
        low=0,
        high=1000,
    ),
    Setting(
        "numNonContactInnerIterations",
        "int",
        1,
        "inner iterations of joint (non-contact) constraints per solver iteration",
        low=1,
        high=1000,
    ),
    Setting(
        "solverResidualThreshold",
        "float",
        1e-7,
        "the solver stops early once its residual is under this",
        low=0.0,
        toward="mujoco.tolerance",
    ),
    Setting(
        "allowedCcdPenetration",
        "float",
        0.04,
        "penetration allowed before continuous collision detection steps in",
        unit="m",
        low=0.0,
    ),
    Setting(
        "enableSAT",
        "bool",
        False,
        "convex-convex contacts by the separating axis test instead of GJK/EPA",
    ),
)
