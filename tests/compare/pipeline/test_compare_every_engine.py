"""Comparing every engine: each engine's ensemble perturbed at a size its state type represents
(:func:`simbridge.compare.run.ensemble.engine_perturbation`), every installed engine by default
with the registered ones left out named, and PhysX beside PyBullet and MuJoCo.

A float32 engine is stood in for by MuJoCo's backend declaring ``state_dtype = "float32"``
under another name, on a copy of the registry that the test restores; its ensembles run in
this process (``workers=0``: a worker process would not have the name registered).
"""

from __future__ import annotations

import importlib.util
import json
from dataclasses import replace

import numpy as np
import pytest

from simbridge import registry
from simbridge.compare import compare, installed_backends, load_scenario, report, summary
from simbridge.compare.run.ensemble import (
    DEFAULT_PERTURB,
    FLOAT_SPACINGS,
    engine_perturbation,
    run_ensembles,
)
from simbridge.exceptions import BackendError, InvalidArgumentError

F32 = "mujoco-f32"
SAPIEN = importlib.util.find_spec("sapien") is not None


@pytest.fixture
def own_registry(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    monkeypatch.setattr(registry, "_LOADED", dict(registry._LOADED))


@pytest.fixture
def float32_engine(own_registry) -> str:
    """MuJoCo's backend under another name, declaring a float32 state."""
    base = registry.load_backend("mujoco")
    registry.register(F32, "simbridge.backends.mujoco:MujocoBackend", requires=("mujoco",))
    registry._LOADED[F32] = type("Float32Mujoco", (base,), {"state_dtype": "float32"})
    return F32


# ---------------------------------------------------------------- the rule


def test_the_rule_is_the_requested_size_or_spacings_of_the_engines_type():
    sc = load_scenario("r2d2")  # r2d2 spawned at z 0.1 m, the plane at 0
    assert max(abs(c) for r in sc.robots for c in r.position) == 0.1
    # float64: the requested size stands (its spacing is 1e-17 at 0.1)
    assert engine_perturbation((1e-9, 1e-9), "float64", sc) == (1e-9, 1e-9)
    # float32: 8 spacings at the largest spawn coordinate (m) and at 1 (rad)
    m, rad = engine_perturbation((1e-9, 1e-9), "float32", sc)
    assert (
        m == FLOAT_SPACINGS * float(np.spacing(np.float32(0.1))) == pytest.approx(5.96e-8, rel=1e-3)
    )
    assert (
        rad
        == FLOAT_SPACINGS * float(np.spacing(np.float32(1.0)))
        == pytest.approx(9.54e-7, rel=1e-3)
    )
    # a requested size above the floor stands
    assert engine_perturbation((1e-3, 2e-3), "float32", sc) == (1e-3, 2e-3)
    # the floor follows the largest spawn coordinate: a robot 10 m out
    far = replace(sc, robots=(sc.robots[0], replace(sc.robots[1], position=(-10.0, 0.0, 0.1))))
    m_far, _ = engine_perturbation((1e-9, 1e-9), "float32", far)
    assert m_far == FLOAT_SPACINGS * float(np.spacing(np.float32(10.0))) > 100 * m


def test_state_dtype_is_declared_by_the_backend_class(float32_engine):
    assert registry.state_dtype("pybullet") == "float64"
    assert registry.state_dtype("mujoco") == "float64"
    assert registry.state_dtype(float32_engine) == "float32"
    registry.register("bad", "simbridge.backends.mujoco:MujocoBackend")
    registry._LOADED["bad"] = type(
        "Bad", (registry.load_backend("mujoco"),), {"state_dtype": "f16"}
    )
    with pytest.raises(BackendError, match="state_dtype 'f16'"):
        registry.state_dtype("bad")


def test_each_engine_gets_its_size_in_the_same_directions(float32_engine):
    sc = load_scenario("r2d2").truncated(0.05)
    engines = [("pybullet", "pybullet"), (float32_engine, "pybullet")]
    a, b = run_ensembles(sc, engines, "base_distance", size=4, workers=0)
    requested = (DEFAULT_PERTURB, DEFAULT_PERTURB)
    assert (a.state_dtype, a.perturbation) == ("float64", requested)
    assert b.state_dtype == "float32"
    assert b.perturbation == engine_perturbation(requested, "float32", sc)
    assert b.perturbation[0] > 50 * requested[0]
    for mine, theirs, size in (
        (a.offsets_m, b.offsets_m, (a.perturbation[0], b.perturbation[0])),
        (a.offsets_rad, b.offsets_rad, (a.perturbation[1], b.perturbation[1])),
    ):
        assert not mine[0].any() and not theirs[0].any()  # the nominal runs
        np.testing.assert_allclose(np.linalg.norm(mine[1:], axis=-1), size[0])
        np.testing.assert_allclose(np.linalg.norm(theirs[1:], axis=-1), size[1])
        np.testing.assert_allclose(mine[1:] / size[0], theirs[1:] / size[1], rtol=1e-12)


def test_report_and_summary_say_which_size_each_engine_got(float32_engine, tmp_path):
    c = compare(
        "r2d2", ["pybullet", float32_engine], duration=0.1, ensemble=3, workers=0, resync_every=0
    )
    s = summary(c)
    want = engine_perturbation((1e-9, 1e-9), "float32", c.scenario)
    engines = s["ensemble"]["engines"]
    assert engines["pybullet"]["perturbation"] == {
        "position": 1e-9,
        "orientation": 1e-9,
        "state_dtype": "float64",
    }
    assert engines[float32_engine]["perturbation"] == {
        "position": want[0],
        "orientation": want[1],
        "state_dtype": "float32",
    }
    assert s["ensemble"]["perturbation"] == {"position": 1e-9, "orientation": 1e-9}
    text = (report(c, tmp_path, plots=False, trajectories=False)).read_text()
    line = f"{float32_engine} (float32) {want[0]:.3g} m and {want[1]:.3g} rad"
    assert line in text and text.count(line) == 2  # the opening lines and the verdict section
    # two float64 engines: no per-engine key, no sentence (the summary as before)
    plain = summary(compare("r2d2", ["pybullet", "mujoco"], duration=0.1, ensemble=2, workers=0))
    assert all("perturbation" not in e for e in plain["ensemble"]["engines"].values())


# ---------------------------------------------------------------- default backends


def test_installed_backends_are_the_registered_ones_that_load(own_registry):
    registry.register("ghost", "no_such_package.backend:Ghost", requires=("no_such_engine_mod",))
    names, left_out = installed_backends()
    assert names[:2] == ["pybullet", "mujoco"]
    assert ("physx" in names) == SAPIEN and ("physx" in left_out) != SAPIEN
    assert set(names) | set(left_out) == set(registry.available_backends())
    assert "no_such_engine_mod" in left_out["ghost"]
    for name in names:
        assert registry.unavailable_reason(name) is None


def test_by_default_compare_runs_every_installed_engine(own_registry, tmp_path):
    registry._REGISTRY.pop("physx", None)  # exactly pybullet and mujoco installed, and a ghost
    registry.register("ghost", "no_such_package.backend:Ghost", requires=("no_such_engine_mod",))
    c = compare("pendulum", duration=0.2, ensemble=1)
    assert c.backends == ("pybullet", "mujoco")
    assert list(c.left_out) == ["ghost"] and "no_such_engine_mod" in c.left_out["ghost"]
    s = summary(c)
    assert s["left_out"] == c.left_out
    text = (report(c, tmp_path, plots=False, trajectories=False)).read_text()
    assert text.count("Registered engines left out, not installed here: ghost (") == 1
    written = json.loads((tmp_path / "summary.json").read_text())
    assert not any("left out" in x for x in written["headline"]["text"])  # a line below it
    # named backends: nothing left out, no key (the two-engine summary as before)
    named = compare("pendulum", ["pybullet", "mujoco"], duration=0.2, ensemble=1)
    assert named.left_out == {} and "left_out" not in summary(named)
    assert json.dumps(summary(named)["backends"]) == json.dumps(s["backends"])


def test_by_default_fewer_than_two_installed_is_refused(own_registry):
    for name in list(registry._REGISTRY):
        if name != "pybullet":
            registry._REGISTRY.pop(name)
    registry.register("ghost", "no_such_package.backend:Ghost", requires=("no_such_engine_mod",))
    with pytest.raises(InvalidArgumentError, match="backends.*installed here: \\['pybullet'\\]"):
        compare("pendulum", duration=0.1, ensemble=1)


# ---------------------------------------------------------------- PhysX beside the others


@pytest.mark.needs_backend("physx")
def test_three_engines_with_physx_every_pair_judged(tmp_path):
    c = compare(
        "r2d2",
        ["pybullet", "mujoco", "physx"],
        duration=0.25,
        ensemble=2,
        workers=0,
        resync_every=0,
    )
    assert c.labels == ("pybullet", "mujoco", "physx")
    assert [(p.a, p.b) for p in c.pairs] == [(0, 1), (0, 2), (1, 2)]
    assert all(p.verdict is not None for p in c.pairs)
    physx = c.ensembles[2]
    assert physx.state_dtype == registry.state_dtype("physx")
    assert physx.perturbation == engine_perturbation((1e-9, 1e-9), physx.state_dtype, c.scenario)
    s = summary(c)
    assert [p["labels"] for p in s["pairs"]] == [
        ["pybullet", "mujoco"],
        ["pybullet", "physx"],
        ["mujoco", "physx"],
    ]
    text = (report(c, tmp_path, plots=False, trajectories=False)).read_text()
    assert "# r2d2: pybullet, mujoco and physx" in text
    assert "Every pair of the 3 engines, judged on the " in text
    assert "\n\n- pybullet and mujoco: " in text


def test_the_command_line_runs_every_installed_engine_by_default(own_registry, tmp_path, capsys):
    from simbridge.cli import main

    registry._REGISTRY.pop("physx", None)
    registry.register("ghost", "no_such_package.backend:Ghost", requires=("no_such_engine_mod",))
    out = tmp_path / "r"
    args = ["compare", "pendulum", "--duration", "0.2", "--ensemble", "1", "--no-plots"]
    assert main([*args, "--out", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["backends"] == ["pybullet", "mujoco"] and list(s["left_out"]) == ["ghost"]
    assert "Registered engines left out, not installed here: ghost (" in capsys.readouterr().out
