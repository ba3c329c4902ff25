"""simbridge installed as users install it: a wheel built from this checkout carries every
package (every folder with an ``__init__.py`` under the folders pyproject.toml maps into
``simbridge``) and the robots, states the Python versions it supports, installs into a clean
virtual environment with no checkout and runs the README's main job there (shortened); an
sdist built without a C compiler installs with the Python step loop and says so at build, in
``simbridge info`` and when the first MuJoCo Sim is made; a step loop built for another MuJoCo
is said the same way.

Time (pip's cache warm, a 2-core machine shared with other jobs): the whole file 124 s; the sdist
and the wheel built from it 30 s, the clean environment 45 s (dependencies from pip's cache, no
.pyc compiled), its comparison 6 s, the compiler-less wheel 35 s (its own isolated build
environment), the loop for another MuJoCo 3 s.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # among the slowest files: left out of the quick tier

ROOT = Path(__file__).resolve().parents[1]
FALLBACK = "the MuJoCo backend will step in Python, about 12x slower"  # setup.py's build warning
MAIN_JOB_EXTRAS = ("report", "physx")  # what the README's command 1 installs (test_readme)


def _compiler() -> str | None:
    cc = (sysconfig.get_config_var("CC") or "cc").split()[0]
    return shutil.which(cc) or shutil.which("gcc")


def _run(cmd: list[str], **kw) -> subprocess.CompletedProcess:
    proc = subprocess.run(cmd, capture_output=True, text=True, **kw)
    assert proc.returncode == 0, f"{cmd}: {proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    return proc


@pytest.fixture(scope="module")
def dists(tmp_path_factory) -> Path:
    """The sdist, and the wheel built from it, as ``python -m build`` makes them: the wheel
    from the sdist's clean tree, never from files an earlier build left in the checkout's
    build/ (a wheel built in place picked up a stale ``_mjkernel.cpython-311-*.so`` there)."""
    out = tmp_path_factory.mktemp("dist")
    _run([sys.executable, "-m", "build", "-o", str(out), str(ROOT)])
    return out


@pytest.fixture(scope="module")
def wheel(dists) -> Path:
    (path,) = dists.glob("simbridge-*.whl")
    return path


@pytest.fixture(scope="module")
def sdist(dists) -> Path:
    (path,) = dists.glob("simbridge-*.tar.gz")
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


def test_wheel_holds_every_package_under_the_mapped_folders(wheel):
    """setup.py finds the packages: a subpackage added under any mapped folder is in the wheel."""
    roots = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    names = set(zipfile.ZipFile(wheel).namelist())
    expected = []
    for name, folder in roots["package-dir"].items():
        for init in (ROOT / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(ROOT / folder)
            if all(part.isidentifier() for part in rel.parts):  # no __pycache__, .venv...
                expected.append("/".join([*name.split("."), *rel.parts, "__init__.py"]))
    assert len(expected) >= 15  # today: core 4, backends 4, compare 6, robots 1
    missing = [path for path in expected if path not in names]
    assert not missing, f"packages left out of {wheel.name}: {missing}"


def test_wheel_states_the_python_it_supports(wheel):
    meta = zipfile.ZipFile(wheel).read("simbridge-0.1.0.dist-info/METADATA").decode()
    assert "Requires-Python: >=3.11" in meta.splitlines()
    assert "Classifier: Programming Language :: Python :: 3.11" in meta.splitlines()
    # the compiled step loop keeps to CPython 3.11's limited API: one wheel for 3.11 and later
    assert "-cp311-abi3-" in wheel.name
    loops = [n for n in zipfile.ZipFile(wheel).namelist() if n.endswith((".so", ".pyd"))]
    assert loops in ([], ["simbridge/backends/mujoco/_mjkernel.abi3.so"])


@pytest.fixture(scope="module")
def clean_venv(wheel, tmp_path_factory) -> Path:
    """A new virtual environment, outside the checkout, with the wheel installed as the
    README's command 1 installs the checkout: with the extras ``report`` (the 3D replay) and
    ``physx`` (the third engine), and their dependencies (from pip's cache where it holds them;
    no .pyc compiled: 42 s against 91 s; the two extras add about 8 s of CPU, mostly SAPIEN's
    435 MB unpacked)."""
    venv = tmp_path_factory.mktemp("venv") / "env"
    _run([sys.executable, "-m", "venv", "--without-pip", str(venv)])
    python = venv / "bin" / "python"
    _run(
        [sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-compile"]
        + [f"simbridge[{','.join(MAIN_JOB_EXTRAS)}] @ {wheel.as_uri()}"]
    )
    return venv


def _clean_env(**more: str) -> dict[str, str]:
    """The environment a user's shell would give: no PYTHONPATH into the checkout, nothing of
    simbridge's own settings, a cache of its own."""
    keep = ("PATH", "HOME", "LANG", "TMPDIR", "OPENBLAS_CORETYPE")
    env = {k: v for k, v in os.environ.items() if k in keep}
    return env | more


def test_the_wheel_in_a_clean_venv_runs_the_main_job(wheel, clean_venv, tmp_path):
    """The README's command 1 (``simbridge compare r2d2``: every installed engine, the figures
    and report.html with its 3D replay) from the installed wheel, shortened to 0.5 s of the
    drive and two runs per engine (9 s of CPU; the whole job is about a minute on two cores,
    which the README's own command 1 runs)."""
    python = clean_venv / "bin" / "python"
    where = _run(
        [str(python), "-c", "import simbridge; print(simbridge.__file__)"],
        cwd=tmp_path,
        env=_clean_env(),
    ).stdout.strip()
    package = Path(where).parent
    assert package.is_relative_to(clean_venv) and package.parent.name == "site-packages"
    assert not package.is_relative_to(ROOT)
    out = tmp_path / "report"
    cmd = [str(clean_venv / "bin" / "simbridge"), "compare", "r2d2"]
    cmd += ["--duration", "0.5", "--ensemble", "2", "--no-cache", "--out", str(out)]
    _run(cmd, cwd=tmp_path, env=_clean_env(XDG_CACHE_HOME=str(tmp_path / "cache")))
    summary = json.loads((out / "summary.json").read_text())
    assert summary["backends"] == ["pybullet", "mujoco", "physx"]  # every engine, none left out
    assert (out / "report.md").is_file() and (out / "paths.png").stat().st_size > 10_000
    html = (out / "report.html").read_text(encoding="utf-8")
    assert 'id="replay"' in html and (out / "replay_ghosts.npz").is_file()  # the 3D replay
    assert Path(summary["scenario_file"]).is_relative_to(package)  # the wheel's scenario
    loop = summary["manifest"]["engines"]["mujoco"]["step_loop"]
    if _compiler() is not None:
        assert loop == "compiled (backends/mujoco/_mjkernel.c)", loop
    info = _run(
        [str(clean_venv / "bin" / "simbridge"), "info"], cwd=tmp_path, env=_clean_env()
    ).stdout.splitlines()
    assert info[1] == f"install: a wheel, from {wheel}; imported from {package}"


def test_the_sdist_without_a_compiler_installs_the_python_loop_and_says_so(
    sdist, clean_venv, tmp_path
):
    # CC=/bin/false: the compiler fails as a missing one would; the build goes on without it
    build = _run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-v", "-w", str(tmp_path), str(sdist)],
        env=os.environ | {"CC": "/bin/false"},
    )
    said = [
        line for line in build.stderr.splitlines() + build.stdout.splitlines() if FALLBACK in line
    ]
    assert said, build.stdout[-3000:]
    warning = (
        "simbridge: WARNING: the compiled step loop (backends/mujoco/_mjkernel.c) was not built"
    )
    assert said[0].lstrip().startswith(warning)
    (built,) = tmp_path.glob("simbridge-*.whl")
    assert not [n for n in zipfile.ZipFile(built).namelist() if n.endswith(".so")]
    # installed beside the clean environment's own copy, first on its path
    target = tmp_path / "site"
    _run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--no-deps",
            "-q",
            "--target",
            str(target),
            str(built),
        ]
    )
    env = _clean_env(PYTHONPATH=str(target))
    info = _run([str(clean_venv / "bin" / "simbridge"), "info"], cwd=tmp_path, env=env)
    lines = info.stdout.splitlines()
    assert lines[1] == f"install: a wheel, from {built}; imported from {target / 'simbridge'}"
    mujoco = next(line for line in lines if line.startswith("  mujoco: "))
    assert "step loop: Python, about 12x slower: the compiled step loop is not installed" in mujoco
    code = "import simbridge\nwith simbridge.Sim('mujoco') as sim: sim.step()"
    made = _run([str(clean_venv / "bin" / "python"), "-c", code], cwd=tmp_path, env=env)
    assert (
        "SlowStepWarning: MuJoCo steps in Python, about 12x slower: the compiled step loop "
        "is not installed" in made.stderr
    )


def test_a_loop_built_for_another_mujoco_is_said_not_used(clean_venv, tmp_path):
    """A MuJoCo upgrade under an installed loop: the loop is built here against a copy of the
    headers whose version number is not the installed MuJoCo's, then put in the package's place
    (sys.modules) before the backend loads it."""
    if _compiler() is None:  # pragma: no cover
        pytest.skip("no C compiler: no loop to build")
    python = str(clean_venv / "bin" / "python")
    mujoco_dir = _run(
        [python, "-c", "import mujoco, os; print(os.path.dirname(mujoco.__file__))"]
    ).stdout.strip()
    include = tmp_path / "include"
    shutil.copytree(Path(mujoco_dir) / "include", include)
    header = include / "mujoco" / "mujoco.h"
    text = header.read_text()
    assert "#define mjVERSION_HEADER " in text
    header.write_text(text.replace("#define mjVERSION_HEADER ", "#define mjVERSION_HEADER 1 + "))
    so = tmp_path / ("_mjkernel" + sysconfig.get_config_var("EXT_SUFFIX"))
    _run(
        [
            _compiler(),
            "-O0",
            "-std=c11",
            "-shared",
            "-fPIC",
            '-DSIMBRIDGE_MUJOCO_RELEASE="3.99.9"',
            f"-I{include}",
            f"-I{sysconfig.get_paths()['include']}",
            str(ROOT / "backends" / "mujoco" / "_mjkernel.c"),
            "-o",
            str(so),
        ]
    )
    code = f"""
import importlib.util, sys, warnings
name = "simbridge.backends.mujoco._mjkernel"
spec = importlib.util.spec_from_file_location(name, {str(so)!r})
sys.modules[name] = module = importlib.util.module_from_spec(spec)
spec.loader.exec_module(module)
import simbridge
from simbridge.cli.info import described
print(described("mujoco"))
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    with simbridge.Sim("mujoco") as sim:
        print(sim.manifest()["step_loop"])
print(*[str(w.message) for w in caught], sep="\\n")
"""
    out = _run([python, "-c", code], cwd=tmp_path, env=_clean_env()).stdout.splitlines()
    version = _run([python, "-c", "import mujoco; print(mujoco.__version__)"]).stdout.strip()
    said = f"the compiled step loop was built for MuJoCo 3.99.9, this is MuJoCo {version}"
    assert out[0].startswith(f"step loop: Python, about 12x slower: {said}: rebuild it")
    assert out[1].startswith(f"Python ({said}")
    assert any(
        line.startswith(f"MuJoCo steps in Python, about 12x slower: {said}") for line in out[2:]
    )
