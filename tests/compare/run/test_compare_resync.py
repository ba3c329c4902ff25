"""One step from the same state (compare/resync.py): each engine's states set into the other
engine and into a second Sim of its own (the floor), one step each, against the source's next
recorded state. Figures measured with pybullet 3.2.7 and mujoco 4.0.0 (docs/compare.md)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from simbridge.cli import main
from simbridge.compare import compare, report, run
from simbridge.compare.report import summary as compare_summary
from simbridge.compare.report.events import event_words
from simbridge.compare.report.summary_json import event_dict, resync_dict
from simbridge.compare.run.resync import PARTS, default_every, resync
from simbridge.compare.scenario import load_scenario
from simbridge.exceptions import InvalidArgumentError

DOCS = Path(__file__).resolve().parents[3] / "docs" / "compare.md"


@pytest.fixture(scope="module")
def gentle():
    """r2d2-gentle (resting, turning, driving on the plane), both engines, every 6th step."""
    return resync("r2d2-gentle", ["pybullet", "mujoco"])


# ---------------------------------------------------------------- the driver


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
def test_taking_the_state_before_each_step_leaves_the_run_bit_identical(backend):
    seen = []

    def hook(sim, row):
        state = sim.get_state(exact=False)
        seen.append((row, state.time, state.bodies[1].motor_target.copy()))

    plain = run("r2d2-gentle", backend, duration=0.6)
    hooked = run("r2d2-gentle", backend, duration=0.6, before_step=hook)
    for key in ("base_position", "base_orientation", "joint_velocities", "link_positions"):
        assert np.array_equal(getattr(plain.body, key), getattr(hooked.body, key)), key
    assert [r for r, _, _ in seen] == list(range(plain.steps))
    row, t, targets = seen[130]  # in 'turn' (from row 120): its commands are in force
    assert t == pytest.approx(row / 240)
    assert sorted(np.round(targets[[2, 3, 6, 7]], 9)) == [-2.0, -2.0, 2.0, 2.0]


def test_default_every_aims_at_150_points():
    assert default_every(100) == 1 and default_every(980) == 7 and default_every(840) == 6


def test_bad_arguments_are_refused():
    with pytest.raises(InvalidArgumentError, match="every"):
        resync("pendulum", every=0)
    with pytest.raises(InvalidArgumentError, match="quantity"):
        resync("pendulum", quantity="speed")
    with pytest.raises(InvalidArgumentError, match="resync_every"):
        compare("pendulum", ensemble=1, duration=0.05, resync_every=-1)


# ---------------------------------------------------------------- floors


def test_without_contact_every_floor_is_exactly_zero_and_the_engines_nearly_agree():
    r = resync("pendulum", ["pybullet", "mujoco"], every=8)
    assert r.every == 8 and [len(d.rows) for d in r.directions] == [60, 60]
    for d in r.directions:
        assert not d.floor.any()  # a portable restore is exact without contact (both engines)
        assert all(not v.any() for v in d.floor_parts.values())
        # measured 3.5e-14 m (link centres of mass) and 1.7e-11 rad/s: integration rounding
        assert 0 < np.max(d.error) < 1e-12
        assert np.max(d.parts["joint_velocities"]) < 1e-9
    assert r.born() is None


@pytest.mark.parametrize("backend", ["pybullet", "mujoco"])
def test_an_engine_against_itself_is_at_its_floor(backend):
    """Engine A's states into a second Sim of A (the 'other engine') and into a third (the
    floor): both take the same states and steps, so the cross error IS the floor, bit for bit;
    and the floor is the measured one of docs/state_and_contacts.md."""
    r = resync("r2d2-gentle", [backend, backend], labels=["a", "b"], every=10)
    for d in r.directions:
        assert np.array_equal(d.error, d.floor)
        for k in PARTS:
            assert np.array_equal(d.parts[k], d.floor_parts[k])
    floor = r.directions[0].floor_parts
    if backend == "pybullet":  # contact manifolds and their warm start cannot be set
        assert 1e-6 < floor["base_position"].max() < 1e-4  # measured 6.2e-5 m
        assert 0.01 < floor["joint_velocities"].max() < 1.0  # measured 0.22 rad/s
        assert np.median(floor["base_position"]) < 1e-8  # measured 2e-10 m
    else:  # the solver starts cold: the one thing a portable MuJoCo state lacks
        assert floor["base_position"].max() < 1e-10  # measured 1.5e-11 m
        assert floor["base_linear_velocity"].max() < 1e-7  # measured 1e-8 m/s
        assert floor["joint_velocities"].max() < 1e-12  # measured 0


# ---------------------------------------------------------------- across engines


def test_on_r2d2_gentle_the_engines_differ_far_above_their_floors(gentle):
    a_to_b, b_to_a = gentle.directions
    assert (a_to_b.source, a_to_b.target) == ("pybullet", "mujoco")
    assert gentle.every == 6 and len(a_to_b.rows) == 140
    floors = [d.floor for d in gentle.directions]
    for d in gentle.directions:
        assert d.failed == 0
        # measured: largest 0.75 mm each way (the landing) against floors of 5.6e-5 and 1.5e-11 m
        assert np.max(d.error) > 10 * max(f.max() for f in floors)
        # measured: medians 6.4e-5 and 5.3e-5 m against floor medians 3.5e-10 and 3e-20 m
        assert np.median(d.error) > 1e4 * max(np.median(f) for f in floors)
    s = resync_dict(gentle)
    born = s["born"]
    assert born is not None and born["phase"] == "settle"  # the landing at t = 0.025 s
    assert born["time"] == pytest.approx(0.025)
    turn = next(p for p in s["directions"][0]["phases"] if p["phase"] == "turn")
    assert turn["median"] > 1e5 * turn["floor_median"]  # measured 1.0e-4 m against 2.9e-11 m


def test_the_worst_steps_come_with_the_source_engines_events(gentle):
    worst = gentle.directions[0].worst
    assert len(worst) == 5
    assert [w.error for w in worst] == sorted((w.error for w in worst), reverse=True)
    first = worst[0]
    assert first.phase == "settle" and first.time == pytest.approx(0.025)
    kinds = {(e.kind, e.part) for e in first.events}
    assert ("contact_made", "left_back_wheel") in kinds  # pybullet lands in that very step
    words = [event_words(event_dict(e), "pybullet") for e in first.events]
    assert all(w.startswith("pybullet's r2d2") for w in words)


def test_the_tutorial_drive_differs_from_its_first_step():
    """r2d2 spawned 0.37 m inside the ground: the two engines push it out differently at once."""
    r = resync("r2d2", ["pybullet", "mujoco"])
    born = r.born()
    assert born is not None and born.time == 0 and born.phase == "settle"
    assert born.error > 0.01  # measured 6.8 cm in one step (16 m/s of base velocity)


# ---------------------------------------------------------------- summary, report, flag


def test_summary_report_and_docs(tmp_path):
    c = compare("r2d2-gentle", ["pybullet", "mujoco"], ensemble=1, duration=0.3)
    s = compare_summary(c)
    r = s["resync"]
    assert r["every"] == 1 and r["quantity"] == "base_distance" and r["unit"] == "m"
    assert [(d["source"], d["target"]) for d in r["directions"]] == [
        ("pybullet", "mujoco"),
        ("mujoco", "pybullet"),
    ]
    assert set(r["floors"]) == {"pybullet", "mujoco"}
    assert r["directions"][0]["points"] == 72
    assert r["largest"]["value"] == max(d["max"]["value"] for d in r["directions"])
    d = r["directions"][0]
    keys = {"resync"} | set(r) | set(r["largest"]) | set(r["born"]) | set(d)
    keys |= set(d["max"]) | set(d["parts"]["base_position"]) | set(d["phases"][0])
    keys |= set(d["worst"][0]) | set(PARTS)
    docs = DOCS.read_text()
    missing = sorted(k for k in keys if f"`{k}`" not in docs)
    assert not missing, f"docs/compare.md does not describe {missing}"
    json.dumps(r)  # JSON-ready

    path = report(c, tmp_path)
    text = path.read_text()
    assert "## One step from the same state" in text and "](resync.png)" in text
    assert (tmp_path / "resync.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    line = next(x for x in text.splitlines() if x.startswith("One step from the same state"))
    assert re.search(
        r"each engine's own floor, at its largest: pybullet .+, mujoco .+\): the model error is "
        r"born .+ against (pybullet|mujoco)'s own floor of .+ at that step\)",
        line,
    )
    assert text.count("](resync.png)") == 1
    written = json.loads((tmp_path / "summary.json").read_text())
    assert "resync.png" in written["files"] and written["resync"]["every"] == 1


def test_the_resync_every_flag(tmp_path, capsys):
    args = ["compare", "pendulum", "--ensemble", "1", "--duration", "0.2", "--no-plots"]
    assert main([*args, "--out", str(tmp_path / "a"), "--resync-every", "5"]) == 0
    assert len(capsys.readouterr().out.splitlines()) <= 6  # the short headline; report.md says:
    out = (tmp_path / "a" / "report.md").read_text()
    s = json.loads((tmp_path / "a" / "summary.json").read_text())
    # every installed engine: with more than two, each pair's line names its pair
    pair = "the engines" if len(s["labels"]) == 2 else "pybullet and mujoco"
    assert f"One step from the same state, {pair} differ by up to" in out
    assert "no model error shows at this scale" in out  # the pendulum: floors 0, error 1e-14
    assert s["resync"]["every"] == 5 and s["resync"]["directions"][0]["points"] == 10
    assert main([*args, "--out", str(tmp_path / "b"), "--resync-every", "0"]) == 0
    assert "One step" not in (tmp_path / "b" / "report.md").read_text()
    s = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert s["resync"] is None
    assert main([*args, "--resync-every", "-1"]) == 2
    assert "--resync-every" in capsys.readouterr().err


def test_a_closed_loop_controllers_commands_travel_with_the_state():
    """r2d2-goto's PD controller commands the wheels inside the step loop: the state taken
    after it carries those commands, so MuJoCo's own floor stays at its cold-start size (a
    state without them would brake the wheels: errors of cm/s)."""
    sc = load_scenario("r2d2-goto").truncated(0.5)
    r = resync(sc, ["mujoco", "pybullet"], every=4)
    mujoco = r.directions[0]
    assert mujoco.floor_parts["base_linear_velocity"].max() < 1e-7
    assert mujoco.floor_parts["joint_velocities"].max() < 1e-9
    assert mujoco.failed == 0 and np.isfinite(mujoco.error).all()
