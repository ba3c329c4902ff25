"""The one-step resync over every pair of engines: each pair's two jobs (a two-engine study's
jobs and keys as they were), each pair's figures in summary.json, report.md and its figure,
``simbridge report DIR`` rebuilding them (and a study recorded when the first pair alone had a
resync), and a float32 engine's rounding of the state set into it."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from simbridge.cli import main
from simbridge.compare.report.resync import resync_file
from simbridge.compare.run.asked import engine_labels, headline_quantity
from simbridge.compare.run.ensemble import EnsembleRunner
from simbridge.compare.run.jobs import Job, file_hashes
from simbridge.compare.run.studyjobs import Plan
from simbridge.compare.scenario import load_scenario

EVERY = 4


def _plan(names: tuple[str, ...], **kw: Any) -> tuple[Plan, Any]:
    """The Plan compare() makes for ``names`` on a short pendulum (no engine runs)."""
    sc = load_scenario("pendulum").truncated(0.1)
    dt = sc.timestep
    scaled = {dt: sc, dt / 2: sc.with_timestep(dt / 2)}
    todo = [(slot, d) for slot in range(len(names)) for d in (dt, dt / 2)]
    profiles = (sc.profile,) * len(names)
    q = headline_quantity(sc)
    runner = EnsembleRunner(sc, list(zip(names, profiles, strict=True)), q, size=2, workers=0)
    labels = engine_labels(names, profiles)
    return Plan(scaled, [dt], todo, names, profiles, labels, q, runner, EVERY, **kw), sc


def test_a_two_engine_study_keeps_its_resync_jobs_and_keys():
    names = ("pybullet", "mujoco")
    plan, sc = _plan(names)
    # the two jobs a two-engine study has always had: A's states into B, B's into A
    files = file_hashes(sc)
    by_hand = [
        Job.of(
            "resync",
            sc,
            names[i],
            sc.profile,
            files,
            target=(names[1 - i], sc.profile),
            labels=(names[i], names[1 - i]),
            every=EVERY,
            quantity=plan.quantity,
        ).key
        for i in (0, 1)
    ]
    assert plan.resync == by_hand
    assert plan.resync_pairs == {(0, 1): by_hand}
    kinds = [j.kind for j in plan.jobs]  # the order study.json records them in
    assert kinds == ["nominal", "half-step"] * 2 + ["resync"] * 2 + ["member"] * 2


def test_every_pair_of_three_engines_gets_its_two_resync_jobs():
    two, _ = _plan(("pybullet", "mujoco"))
    three, _ = _plan(("pybullet", "mujoco", "pybullet"))
    assert list(three.resync_pairs) == [(0, 1), (0, 2), (1, 2)]
    keys = [k for pair in three.resync_pairs.values() for k in pair]
    assert len(set(keys)) == 6
    assert three.resync_pairs[(0, 1)] == two.resync == three.resync  # the first pair's: as two
    jobs = {k: three.by_key[k] for k in keys}
    for (a, b), (ab, ba) in three.resync_pairs.items():
        assert jobs[ab].labels == (three.labels[a], three.labels[b])
        assert jobs[ba].labels == (three.labels[b], three.labels[a])
    kinds = [j.kind for j in three.jobs]  # the third engine's runs are the first's: one job
    assert kinds[:10] == ["nominal", "half-step"] * 2 + ["resync"] * 6
    assert set(kinds[10:]) == {"member"}
    first, _ = _plan(("pybullet", "mujoco", "pybullet"), resync_pairs=1)
    assert first.resync_pairs == {(0, 1): two.resync}


def test_the_figure_names():
    assert resync_file(["pybullet", "mujoco"], True) == "resync.png"
    assert resync_file(["pybullet", "physx"], False) == "resync_pybullet_physx.png"
    assert resync_file(["pybullet (2)", "mujoco"], False) == "resync_pybullet-2_mujoco.png"


def _compare(cache: Path, out: Path) -> None:
    argv = ["compare", "double-pendulum", "--backends", "pybullet", "mujoco", "pybullet"]
    argv += ["--timestep", "1/30", "--duration", "1", "--ensemble", "2"]
    argv += ["--resync-every", str(EVERY), "--workers", "0", "--no-replay"]
    assert main([*argv, "--cache", str(cache), "--out", str(out)]) == 0


def _masked(v: Any) -> Any:
    if isinstance(v, dict):
        return {k: _masked(x) for k, x in v.items() if k not in ("wall_time", "command_line")}
    if isinstance(v, list):
        return [_masked(x) for x in v]
    return v


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """Three engines (PyBullet twice, MuJoCo) on a short double pendulum, with its cache."""
    root = tmp_path_factory.mktemp("resync-pairs")
    cache, out = root / "cache", root / "rep"
    _compare(cache, out)
    return cache, out


def test_three_engines_resync_every_pair_and_a_rebuild_gives_it_again(study):
    cache, out = study
    s = json.loads((out / "summary.json").read_text("utf-8"))
    text = (out / "report.md").read_text("utf-8")
    assert [p["labels"] for p in s["pairs"]] == [
        ["pybullet", "mujoco"],
        ["pybullet", "pybullet (2)"],
        ["mujoco", "pybullet (2)"],
    ]
    assert s["resync"] == s["pairs"][0]["resync"]  # the top-level key: the first pair's
    section = text.split("\n## One step from the same state\n", 1)[1].split("\n## ", 1)[0]
    for k, p in enumerate(s["pairs"]):
        r = p["resync"]
        a, b = p["labels"]
        assert [(d["source"], d["target"]) for d in r["directions"]] == [(a, b), (b, a)]
        assert all(d["points"] > 0 and d["failed"] == 0 for d in r["directions"])
        assert all("rounding" not in d for d in r["directions"])  # float64 engines only
        assert f"\n### {a} and {b}\n" in section
        assert f"One step from the same state, {a} and {b} differ by up to " in section
        figure = resync_file([a, b], k == 0)
        assert (out / figure).is_file() and f"![resync]({figure})" in section
        for d in r["directions"]:  # a row each in the table of every direction
            assert f"| {a} and {b} | {d['source']} -> {d['target']} |" in section
    # the same engine's two Sims step alike: PyBullet against itself is the floor
    same = s["pairs"][1]["resync"]
    assert same["largest"]["value"] <= max(same["floors"].values()) + same["precision_floor"]
    figures = sorted(p.name for p in out.glob("resync*.png"))
    assert figures == sorted(resync_file(p["labels"], k == 0) for k, p in enumerate(s["pairs"]))
    assert "## Figures" not in text or "![resync" not in text.split("## Figures", 1)[1]
    # rebuilt from the cache alone: the same report, summary and figures
    before = {p.name: p.read_bytes() for p in out.glob("*.png")}
    for f in out.iterdir():
        if f.is_file() and f.name != "study.json":
            f.unlink()
    assert main(["report", str(out), "--cache", str(cache), "--no-replay"]) == 0
    assert (out / "report.md").read_text("utf-8") == text
    assert _masked(json.loads((out / "summary.json").read_text("utf-8"))) == _masked(s)
    assert {p.name: p.read_bytes() for p in out.glob("*.png")} == before


def test_a_study_recorded_with_the_first_pairs_resync_alone_rebuilds(study, tmp_path):
    cache, out = study
    old = tmp_path / "old"
    old.mkdir()
    record = json.loads((out / "study.json").read_text("utf-8"))
    first = [j for j in record["jobs"] if j["kind"] == "resync"][:2]
    record["jobs"] = [j for j in record["jobs"] if j["kind"] != "resync" or j in first]
    (old / "study.json").write_text(json.dumps(record), encoding="utf-8")
    assert main(["report", str(old), "--cache", str(cache), "--no-replay"]) == 0  # no engine runs
    s = json.loads((old / "summary.json").read_text("utf-8"))
    assert s["pairs"][0]["resync"] == s["resync"] is not None
    assert s["pairs"][1]["resync"] is None and s["pairs"][2]["resync"] is None
    text = (old / "report.md").read_text("utf-8")
    assert "\n### pybullet and mujoco\n" in text and "\n### pybullet and pybullet (2)\n" not in text
    assert sorted(p.name for p in old.glob("resync*.png")) == ["resync.png"]


@pytest.mark.needs_backend("physx")
def test_physx_holds_a_state_set_into_it_rounded_to_float32():
    """What Direction.rounding assumes: PhysX steps from the float32 rounding of the state set
    (read back before its step, the base and the joints are the state's float32 values), and
    rounding its own states changes nothing but float64 composition noise."""
    from simbridge.compare.run.resync import _rounding, _World

    sc = load_scenario("r2d2")
    source, target = _World(sc, "mujoco", sc.profile), _World(sc, "physx", sc.profile)
    try:
        for _ in range(40):
            source.sim.step()
        state = source.sim.get_state(exact=False)
        target.sim.set_state(state)
        held = target.sim.get_state(exact=False)
        mine = next(b for b in state.bodies if b.body == source.body)
        got = next(b for b in held.bodies if b.body == target.body)
        for field in ("base_position", "base_linear_velocity", "joint_positions"):
            want = np.asarray(getattr(mine, field), dtype=np.float32).astype(np.float64)
            assert np.array_equal(np.asarray(getattr(got, field)), want), field
        rounded = _rounding(state, source.body, "float32")
        assert 0 < rounded["base_position"] < 1e-6  # float32 spacing at r2d2's metre scale
        again = _rounding(held, target.body, "float32")  # PhysX's own state: float32 values
        assert {k: v for k, v in again.items() if k != "base_orientation"} == dict.fromkeys(
            again.keys() - {"base_orientation"}, 0.0
        )
        # its base orientation is read through the centre of mass's frame in float64: 3e-23 rad
        assert again["base_orientation"] < 1e-15
    finally:
        source.sim.close()
        target.sim.close()
