"""A built wheel carries the whole package: core, backends, compare and the robots."""

from __future__ import annotations

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # among the slowest files: left out of the quick tier

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    proc = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(out), str(ROOT)],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    (path,) = out.glob("simbridge-*.whl")
    return path


def test_wheel_contains_every_package_and_the_robots(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    for required in (
        "simbridge/__init__.py",
        "simbridge/sim/core.py",
        "simbridge/py.typed",
        "simbridge/backends/pybullet/backend.py",
        "simbridge/backends/mujoco/backend.py",
        "simbridge/backends/mujoco/loop.py",
        "simbridge/backends/physx/window_process.py",  # PhysX's window and its shaders
        "simbridge/backends/physx/window_shader/gbuffer.vert",
        "simbridge/backends/physx/window_shader/gbuffer.frag",
        "simbridge/compare/__init__.py",
        "simbridge/compare/pipeline.py",
        "simbridge/compare/scenario/reader.py",  # every stage of the pipeline
        "simbridge/compare/run/trajectory.py",
        "simbridge/compare/analysis/verdict.py",
        "simbridge/compare/report/markdown.py",
        "simbridge/compare/scenarios/r2d2-goto.toml",
        "simbridge/compare/scenarios/goto.py",  # a shipped scenario's controller, beside it
        "simbridge/envs/env.py",  # the Gymnasium environments and their shipped tasks
        "simbridge/envs/tasks/cartpole.toml",
        "simbridge/envs/tasks/a1_stand.toml",
        "simbridge/envs/policies/cartpole_ppo.npz",  # the shipped trained policy, and as ONNX
        "simbridge/envs/policies/cartpole_ppo.onnx",
        "simbridge/robots/r2d2.urdf",
        "simbridge/robots/plane.urdf",
        "simbridge/robots/plane.mtl",  # the ground's checker (its look alone)
        "simbridge/robots/plane_checker.png",
        "simbridge/robots/l_finger.stl",
    ):
        assert required in names, f"{required} missing from {wheel.name}"


def test_wheel_carries_the_compiled_step_loop_where_a_compiler_exists(wheel):
    import shutil
    import sysconfig

    cc = (sysconfig.get_config_var("CC") or "cc").split()[0]
    if not (shutil.which(cc) or shutil.which("gcc")):  # pragma: no cover
        pytest.skip("no C compiler: the wheel is built without backends/mujoco/_mjkernel.c")
    names = zipfile.ZipFile(wheel).namelist()
    assert any(
        n.startswith("simbridge/backends/mujoco/_mjkernel") and n.endswith(".so") for n in names
    )


def test_installed_wheel_imports_and_finds_the_robots(wheel, tmp_path):
    target = tmp_path / "site"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--no-deps",
            "-q",
            "--target",
            str(target),
            str(wheel),
        ],
        check=True,
    )
    code = (
        "import simbridge, simbridge.model.urdf as u; "
        "s = u.resolve_source('r2d2'); print(s.path); "
        "m = u.parse_urdf(s); print(len(m.joints))"
    )
    # Run from an empty folder with only the wheel's copy on the path (dependencies come from
    # this environment's site-packages, which stays on sys.path after the target).
    proc = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        env={"PYTHONPATH": str(target), "PATH": ""},
    )
    assert proc.returncode == 0, proc.stderr
    path, joints = proc.stdout.split()
    assert path.startswith(str(target)) and path.endswith("simbridge/robots/r2d2.urdf")
    assert joints == "15"
