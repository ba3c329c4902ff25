"""A job's key holds the versions of numpy and of its own engine's library only: installing or
upgrading another engine keeps every cached result; an upgrade of its own engine does not. A
rebuild refused because keys differ says what changed."""

from __future__ import annotations

import importlib.metadata
import json
from types import SimpleNamespace

import pytest

from simbridge import registry
from simbridge.cli import main
from simbridge.compare.run import jobs as jobs_module
from simbridge.compare.run.jobs import Job
from simbridge.compare.scenario import load_scenario
from simbridge.exceptions import InvalidArgumentError


@pytest.fixture
def versions(monkeypatch):
    """Installed versions as the test sets them (``{dist: version or None}``); others real."""
    real = importlib.metadata.version
    table: dict[str, str | None] = {}

    def version(dist: str) -> str:
        if dist in table:
            if table[dist] is None:
                raise importlib.metadata.PackageNotFoundError(dist)
            return str(table[dist])
        return real(dist)

    monkeypatch.setattr(importlib.metadata, "version", version)
    for name in ("run_code_digest", "dist_version"):
        cached = getattr(jobs_module, name, None)
        if cached is not None:
            cached.cache_clear()
    yield table
    for name in ("run_code_digest", "dist_version"):
        cached = getattr(jobs_module, name, None)
        if cached is not None:
            cached.cache_clear()


def _keys(sc) -> dict[str, str]:
    for name in ("run_code_digest", "dist_version"):
        cached = getattr(jobs_module, name, None)
        if cached is not None:
            cached.cache_clear()
    keys = {b: Job.of("nominal", sc, b, "pybullet").key for b in ("pybullet", "mujoco", "physx")}
    keys["resync"] = Job.of(
        "resync", sc, "pybullet", "pybullet", target=("mujoco", "pybullet"), every=1
    ).key
    return keys


def test_a_key_sees_its_own_engine_version_only(versions):
    sc = load_scenario("pendulum").truncated(0.1)
    versions["sapien"] = None
    before = _keys(sc)
    versions["sapien"] = "3.0.3"  # PhysX installed
    after = _keys(sc)
    assert after["pybullet"] == before["pybullet"]
    assert after["mujoco"] == before["mujoco"]
    assert after["resync"] == before["resync"]
    assert after["physx"] != before["physx"]
    versions["pybullet"] = "0.0.1"  # PyBullet upgraded: its jobs and its resync's change
    upgraded = _keys(sc)
    assert upgraded["pybullet"] != after["pybullet"]
    assert upgraded["resync"] != after["resync"]
    assert upgraded["mujoco"] == after["mujoco"]
    assert upgraded["physx"] == after["physx"]
    versions["numpy"] = "0.0.1"  # numpy counts for every engine
    with_numpy = _keys(sc)
    assert all(with_numpy[k] != upgraded[k] for k in with_numpy)


def test_a_registered_backend_declares_its_engine_distributions(monkeypatch):
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    registry.register("thirdparty", "nowhere.mod:Cls", requires=("eng",), engine_dists=("eng-x",))
    assert registry.engine_dists("thirdparty") == ("numpy", "eng-x")
    registry.register("bymodule", "nowhere.mod:Cls", requires=("eng",))
    assert registry.engine_dists("bymodule") == ("numpy", "eng")
    assert registry.engine_dists("pybullet") == ("numpy", "pybullet")
    assert registry.engine_dists("physx") == ("numpy", "sapien")
    with pytest.raises(InvalidArgumentError, match="engine_dists"):
        registry.register("bad", "nowhere.mod:Cls", engine_dists="eng")  # type: ignore[arg-type]


def test_an_entry_point_backend_counts_its_package_and_what_it_requires():
    dist = SimpleNamespace(
        metadata={"Name": "simbridge-drake"},
        requires=["drake>=1.20", "simbridge", "numpy", "pytest; extra == 'test'"],
    )
    ep = SimpleNamespace(name="drake", value="simbridge_drake:Backend", dist=dist)
    assert registry._provider_dists(ep) == ("simbridge-drake", "drake", "numpy")
    assert registry._provider_dists(SimpleNamespace(dist=None)) == ()


def test_a_refused_rebuild_says_which_version_changed(tmp_path, versions, capsys):
    cache, out = tmp_path / "cache", tmp_path / "rep"
    argv = ["compare", "pendulum", "--backends", "pybullet", "pybullet", "--duration", "0.1"]
    argv += ["--ensemble", "1", "--resync-every", "0", "--workers", "0", "--no-replay"]
    assert main([*argv, "--cache", str(cache), "--out", str(out)]) == 0
    recorded = json.loads((out / "study.json").read_text())["inputs"]["versions"]
    assert set(recorded) == {"numpy", "pybullet"}  # the study's engines only
    versions["sapien"] = "9.9.9"  # another engine installed: the report is made again
    _keys(load_scenario("pendulum"))  # (reads the versions again)
    assert main(["report", str(out), "--cache", str(cache), "--no-replay"]) == 0
    was = recorded["pybullet"]
    versions["pybullet"] = "9.9.9"
    _keys(load_scenario("pendulum"))
    capsys.readouterr()
    assert main(["report", str(out), "--cache", str(cache), "--no-replay"]) != 0
    err = capsys.readouterr().err
    assert f"pybullet {was} -> 9.9.9" in err
    assert "numpy" not in err
