"""The core without an engine: lazy imports, the registry, profiles."""

from __future__ import annotations

import subprocess
import sys

import pytest

import simbridge
from simbridge import exceptions as exc
from simbridge.registry import register


def test_import_loads_no_engine_and_no_yourdfpy():
    code = (
        "import sys, simbridge; "
        "print(','.join(m for m in ('pybullet', 'mujoco', 'yourdfpy', 'trimesh', 'matplotlib')"
        " if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_unknown_backend_lists_the_available_ones():
    with pytest.raises(
        exc.UnknownBackendError, match=r"unknown backend 'bullet'.*'mujoco'.*'pybullet'"
    ):
        simbridge.Sim("bullet")


@pytest.fixture
def scratch_registry(monkeypatch):
    """Backends registered by a test vanish after it."""
    monkeypatch.setattr(simbridge.registry, "_REGISTRY", dict(simbridge.registry._REGISTRY))
    monkeypatch.setattr(simbridge.registry, "_LOADED", dict(simbridge.registry._LOADED))


def test_missing_engine_names_the_pip_command(scratch_registry):
    register(
        "ghost",
        "simbridge_ghost.backend:Ghost",
        requires=("simbridge_ghost_engine",),
        pip_name="simbridge-ghost-engine",
    )
    with pytest.raises(exc.BackendNotInstalledError, match="pip install simbridge-ghost-engine"):
        simbridge.Sim("ghost")


def test_profiles_are_explicit_and_printable():
    assert set(simbridge.PROFILES) == {"pybullet", "urdf"}
    pb, urdf = simbridge.PROFILES["pybullet"], simbridge.PROFILES["urdf"]
    assert pb.joint_brake == "pybullet" and urdf.joint_brake == "urdf_friction"
    assert pb.linear_damping == 0.04 and urdf.linear_damping == 0.0
    assert pb.max_joint_velocity == 100.0 and urdf.max_joint_velocity is None
    assert pb.inertia_source == "collision_aabb" and urdf.inertia_source == "file"
    text = str(urdf)
    for entry in ("joint_brake", "inertia_source", "max_joint_velocity", "friction_combine"):
        assert entry in text
    with pytest.raises(
        exc.InvalidProfileError,
        match=r"unknown profile 'bullet' \(did you mean 'pybullet'\?\); valid profiles: "
        r"\['pybullet', 'urdf'\]",
    ):
        simbridge.Sim("pybullet", profile="bullet")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"timestep": 0}, "argument 'timestep': must be a finite number > 0"),
        ({"timestep": float("nan")}, "argument 'timestep'"),
        ({"timestep": 10**400}, "argument 'timestep': must be a finite number > 0"),
        ({"timestep": True}, "argument 'timestep': must be a finite number > 0, got True"),
        ({"timestep": "0.01"}, "argument 'timestep'"),
        ({"gravity": (0, 0)}, "argument 'gravity': expected 3 numbers, got 2"),
        ({"gravity": (0, 0, float("inf"))}, "argument 'gravity': values must be finite"),
    ],
)
def test_bad_sim_arguments(kwargs, message):
    with pytest.raises(exc.InvalidArgumentError, match=message):
        simbridge.Sim("pybullet", **kwargs)


def test_unavailable_reason_names_what_is_missing(scratch_registry):
    assert simbridge.registry.unavailable_reason("pybullet") is None
    register("ghost2", "simbridge_ghost2.backend:Ghost")  # module absent, no engine declared
    assert simbridge.registry.unavailable_reason("ghost2") == (
        "backend module 'simbridge_ghost2' is not installed"
    )
    register("broken", "simbridge.sim:NoSuchClass")  # module present, class missing: a bug
    with pytest.raises(exc.BackendError, match="cannot load 'simbridge.sim:NoSuchClass'"):
        simbridge.registry.unavailable_reason("broken")


@pytest.mark.parametrize(
    ("entry", "value", "message"),
    [
        ("solver_iterations", 2.5, "must be an integer >= 1, got 2.5"),
        ("solver_iterations", 0, "must be an integer >= 1"),
        ("lateral_friction", "x", "must be a finite number >= 0, got 'x'"),
        ("linear_damping", float("nan"), "must be a finite number >= 0"),
        ("restitution", -0.1, "must be a finite number >= 0"),
        ("joint_brake", "bogus", r"must be one of \['pybullet', 'urdf_friction'\]"),
        ("inertia_source", "mesh", r"must be one of \['collision_aabb', 'file'\]"),
        ("max_joint_velocity", -1, "must be None \\(no clamp\\) or a finite number > 0"),
        ("self_collision", "no", "must be True or False"),
        ("gravity", (0, 0), "must be three finite numbers"),
        ("timestep", 0.0, "must be a finite number > 0"),
    ],
)
def test_a_bad_profile_entry_is_refused_when_the_profile_is_made(entry, value, message):
    """Profile entries are checked on creation (before any engine starts: a bad type used to
    raise from inside PyBullet after its connection was opened, and leak it)."""
    with pytest.raises(exc.InvalidArgumentError, match=f"argument 'profile.{entry}': {message}"):
        simbridge.PROFILES["pybullet"].with_(**{entry: value})
    with pytest.raises(exc.InvalidArgumentError):
        simbridge.Profile(name="mine", **{entry: value})


def test_a_backend_name_that_is_not_a_string_is_an_unknown_backend():
    with pytest.raises(exc.UnknownBackendError, match=r"unknown backend \"\['pybullet'\]\""):
        simbridge.Sim(["pybullet"])  # type: ignore[arg-type]


def test_numpy_scalars_are_profile_values():
    import numpy as np

    p = simbridge.PROFILES["pybullet"].with_(
        solver_iterations=np.int64(50),
        apply_joint_damping=np.bool_(False),
        linear_damping=np.float32(0.02),
        max_joint_velocity=np.float64(50.0),
    )
    assert p.solver_iterations == 50 and not p.apply_joint_damping
