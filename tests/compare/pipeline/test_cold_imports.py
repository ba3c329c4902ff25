"""What a fresh process imports: a pool worker running a job imports the run stage, not the
pipeline, analysis or report (``simbridge.compare``'s names load on first use); a report rebuilt
from the cache imports no engine (each shipped backend's state type is declared in the
registry); and ``simbridge.compare``'s public names stay what they were."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from _engines import installed_backends

import simbridge.compare as compare_package
from simbridge import registry
from simbridge.cli import main
from simbridge.exceptions import BackendError, BackendNotInstalledError, InvalidArgumentError

ENGINES = ("pybullet", "mujoco", "sapien")


def _modules_after(code: str) -> list[str]:
    """The modules a fresh interpreter holds after running ``code``."""
    probe = f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    out = subprocess.run(
        [sys.executable, "-c", probe], check=True, capture_output=True, text=True, timeout=120
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def _engine_modules(modules: list[str]) -> list[str]:
    return [
        m
        for m in modules
        if m.split(".")[0] in ENGINES
        or (m.startswith("simbridge.backends.") and not m.startswith("simbridge.backends.settings"))
        and m != "simbridge.backends.locking"
    ]


def test_a_job_imports_the_run_stage_alone():
    modules = _modules_after("import simbridge.compare.run.jobs")
    assert "simbridge.compare.run.jobs" in modules and "simbridge.compare.scenario" in modules
    later = [
        m
        for m in modules
        if m.startswith(
            ("simbridge.compare.pipeline", "simbridge.compare.report", "simbridge.compare.analysis")
        )
    ]
    assert later == []
    assert _engine_modules(modules) == []


def test_every_public_name_is_its_module_s_object():
    import importlib

    assert set(compare_package.__all__) <= set(compare_package._LAZY)
    for name in compare_package.__all__:
        module = importlib.import_module(compare_package._LAZY[name], "simbridge.compare")
        assert getattr(compare_package, name) is getattr(module, name), name
    with pytest.raises(AttributeError, match="no_such_name"):
        compare_package.no_such_name  # noqa: B018


def test_run_and_report_stay_functions_after_their_subpackages_load():
    """``compare.run`` and ``compare.report`` are the functions, whichever loads first: the
    function or the subpackage of the same name (whose import sets the name on the package)."""
    code = (
        "import simbridge.compare.run.jobs, simbridge.compare.report.rebuild\n"
        "from simbridge import compare\n"
        "assert compare.run is sys.modules['simbridge.compare.run.recording'].run\n"
        "assert compare.report is sys.modules['simbridge.compare.report'].report\n"
        "from simbridge.compare import run, report\n"
        "assert callable(run) and callable(report) and run.__name__ == 'run'\n"
        "import simbridge.compare.run.cache\n"
        "assert compare.run is run\n"
    )
    _modules_after(f"import sys\n{code}")


def test_declared_state_types_are_the_classes_own():
    installed = installed_backends()  # in CI, one that does not load fails (tests/_engines.py)
    for name in ("pybullet", "mujoco", "physx"):
        declared = registry.backend_spec(name).state_dtype
        assert declared in registry.STATE_DTYPES
        if name in installed:  # (state_dtype raises BackendNotInstalledError for one that is not)
            assert registry.load_backend(name).state_dtype == declared
            assert registry.state_dtype(name) == declared


def test_a_declared_state_type_is_checked(monkeypatch):
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    monkeypatch.setattr(registry, "_LOADED", dict(registry._LOADED))
    with pytest.raises(InvalidArgumentError, match="state_dtype.*'float16'"):
        registry.register("odd", "simbridge.backends.mujoco:MujocoBackend", state_dtype="float16")
    registry.register("liar", "simbridge.backends.mujoco:MujocoBackend", state_dtype="float32")
    assert registry.state_dtype("liar") == "float32"  # as declared: nothing imported
    with pytest.raises(BackendError, match="registered with state_dtype 'float32'"):
        registry.load_backend("liar")
    # declared, its engine not installed: said so as when the class is imported
    registry.register(
        "absent", "absent_pkg.backend:B", requires=("absent_engine_xyz",), state_dtype="float64"
    )
    with pytest.raises(BackendNotInstalledError, match="absent_engine_xyz"):
        registry.state_dtype("absent")


def test_a_rebuild_imports_no_engine(tmp_path: Path):
    cache, out = tmp_path / "cache", tmp_path / "rep"
    argv = ["compare", "double-pendulum", "--backends", "pybullet", "mujoco"]
    argv += ["--timestep", "1/30", "--ensemble", "4", "--resync-every", "0", "--workers", "0"]
    assert main([*argv, "--cache", str(cache), "--out", str(out), "--no-replay"]) == 0
    (out / "report.md").unlink()
    modules = _modules_after(
        "from simbridge.cli import main\n"
        f"assert main(['report', {str(out)!r}, '--cache', {str(cache)!r}, '--no-replay']) == 0"
    )
    assert (out / "report.md").is_file()
    assert "simbridge.compare.report.rebuild" in modules
    assert _engine_modules(modules) == []
