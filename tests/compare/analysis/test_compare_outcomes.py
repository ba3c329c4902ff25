"""Outcomes measured exactly on hand-made trajectories, success rates and their intervals on known
counts, the headline and report words, and the scenario reader's checks of [[outcomes]]."""

from __future__ import annotations

import math
import textwrap

import numpy as np
import pytest
from _synthetic import quat_x, quat_z, trajectory

from simbridge.compare import Outcome, loads_scenario
from simbridge.compare.analysis.outcomes import success_interval, summarize
from simbridge.compare.errors import ScenarioError, TrajectoryFileError
from simbridge.compare.report.outcomes import outcome_lines, outcomes_section
from simbridge.compare.report.summary_json import outcome_stats_dict
from simbridge.compare.run.outcomes import (
    OutcomeRecord,
    ReachFigures,
    TrackFigures,
    UprightFigures,
    evaluate,
    tilt,
)
from simbridge.compare.run.trajectory import Trajectory
from simbridge.compare.scenario import dumps_scenario

DT = 0.125  # the synthetic trajectories: 16 steps of 1/8 s, 17 instants from t = 0 to 2 s


def moving_x(t):
    """1 m/s along x."""
    return np.stack([t, np.zeros_like(t), np.zeros_like(t)], axis=1)


# ---------------------------------------------------------------- reach


def test_reach_gives_the_first_instant_within_the_radius():
    tr = trajectory(position=moving_x)
    r = evaluate(Outcome.reach("goal", (1.25, 0.0), 0.1), tr)
    assert r.value == 1.25 and r.success is True and r.unit == "s"
    assert r.figures.closest == 0.0 and r.figures.final_distance == 0.75
    # just out of reach: the closest instant is 1/8 m away
    r = evaluate(Outcome.reach("goal", (1.3, 0.2, 0.0), 0.05), tr)
    assert r.value is None and r.success is False
    assert r.figures.closest == pytest.approx(math.hypot(0.05, 0.2), abs=1e-15)


def test_reach_in_the_plane_ignores_height_and_a_link_is_its_centre_of_mass():
    tr = trajectory(position=lambda t: moving_x(t) + np.array([0.0, 0.0, 5.0]))
    assert evaluate(Outcome.reach("xy", (0.5, 0.0), 0.01), tr).value == 0.5
    assert evaluate(Outcome.reach("xyz", (0.5, 0.0, 0.0), 0.01), tr).value is None
    # link l0 sits 1 m above the base
    r = evaluate(Outcome.reach("link", (0.5, 0.0, 6.0), 0.01, link="l0"), tr)
    assert r.value == 0.5
    assert evaluate(Outcome.reach("by index", (0.5, 0.0, 6.0), 0.01, link=0), tr).value == 0.5


def test_reach_with_hold_is_the_settling_time_and_by_is_a_deadline():
    # x = t up to 1 m at t = 1 s, then overshoots and rings: 1.2, 1.05, 0.85, then stays at 1
    x = np.concatenate([np.arange(9) * DT, [1.2, 1.05, 0.85], np.ones(5)])
    tr = trajectory(position=lambda t: np.stack([x, 0 * t, 0 * t], axis=1))
    assert evaluate(Outcome.reach("first", (1.0, 0.0), 0.1), tr).value == 1.0
    settled = evaluate(Outcome.reach("settled", (1.0, 0.0), 0.1, hold=True), tr)
    assert settled.value == 1.5 and settled.success is True  # from row 12 on
    late = evaluate(Outcome.reach("by", (1.0, 0.0), 0.1, hold=True, by=1.25), tr)
    assert late.value == 1.5 and late.success is False
    # leaves for good: never settles
    assert evaluate(Outcome.reach("gone", (0.5, 0.0), 0.1, hold=True), tr).value is None


def test_a_phase_window_counts_time_from_the_phase_start():
    tr = trajectory(position=moving_x, phases=[("a", 0, 8), ("b", 8, 16)])
    r = evaluate(Outcome.reach("in b", (1.5, 0.0), 0.01, phase="b"), tr)
    assert r.value == 0.5  # t = 1.5 s, 0.5 s after b starts
    r = evaluate(Outcome.reach("not in a", (1.5, 0.0), 0.01, phase="a"), tr)
    assert r.value is None and r.figures.final_distance == 0.5
    r = evaluate(Outcome.reach("missing", (1.5, 0.0), 0.01, phase="c"), tr)
    assert r.value is None and r.success is None and "was not run" in r.note


# ---------------------------------------------------------------- upright


def test_tilt_is_measured_against_the_initial_orientation_not_world_z():
    half_pi = math.pi / 2
    # a y-up robot turned upright (90 degrees about x), then tilting 0.1 rad/s further about x
    tr = trajectory(orientation=lambda t: np.stack([quat_x(half_pi + 0.1 * s) for s in t]))
    r = evaluate(Outcome.upright("upright", 0.25), tr)
    assert r.value == pytest.approx(0.2, abs=1e-12) and r.success is True
    assert r.figures.exceeded_at is None and r.figures.final_tilt == pytest.approx(0.2, abs=1e-12)
    r = evaluate(Outcome.upright("strict", 0.105), tr)
    assert r.success is False and r.figures.exceeded_at == 1.125
    # turning about the vertical is no tilt
    spun = trajectory(yaw=lambda t: 3 * t)
    assert np.abs(tilt(spun.body.base_orientation)).max() < 1e-7
    # the window's first instant is the reference
    tr2 = trajectory(
        orientation=lambda t: np.stack([quat_x(0.1 * s) for s in t]),
        phases=[("a", 0, 8), ("b", 8, 16)],
    )
    r = evaluate(Outcome.upright("b only", 1.0, phase="b"), tr2)
    assert r.value == pytest.approx(0.1, abs=1e-12)


# ---------------------------------------------------------------- track, final pose, effort


def test_track_joints_against_their_recorded_targets():
    tr = trajectory(q=lambda t: np.stack([0.1 + 0 * t, t], axis=1))
    b = tr.bodies["bot"]
    b.joint_targets[5:, 0] = 0.0  # position target 0 from row 5: error 0.1
    b.joint_modes[5:, 0] = 2
    b.joint_targets[1:, 1] = 9.0  # a velocity target on joint 1: not a position to track
    b.joint_modes[1:, 1] = 1
    r = evaluate(Outcome.track("q"), tr)
    assert r.value == pytest.approx(0.1, abs=1e-15) and r.figures.samples == 12
    assert r.unit == "rad" and r.success is None
    r = evaluate(Outcome.track("bounded", joints=["j0"], max=0.05), tr)
    assert r.success is False
    # velocity tracking: joint 1's velocity (zero) against 9 rad/s over 16 rows
    r = evaluate(Outcome.track("v", quantity="velocity"), tr)
    assert r.value == 9.0 and r.figures.samples == 16 and r.unit == "rad/s"
    # constant targets, every instant: joint 1 (q = t) against 1: sqrt(mean((t - 1)^2))
    t = tr.time
    r = evaluate(Outcome.track("const", joints=[1], targets=[1.0]), tr)
    assert r.value == pytest.approx(math.sqrt(np.mean((t - 1) ** 2)), abs=1e-15)


def test_track_a_link_against_timed_points():
    tr = trajectory(position=moving_x)
    points = [(0.0, 0.0, 0.0), (1.0, 1.0, 0.0)]  # (t, x, y): held from their time
    r = evaluate(Outcome.track("path", points=points), tr)
    t = tr.time
    err = np.where(t < 1.0, t, t - 1.0)
    assert r.value == pytest.approx(math.sqrt(np.mean(err**2)), abs=1e-15)
    assert r.figures.max_error == 1.0 and r.unit == "m"


def test_final_pose_of_a_position_or_of_joints():
    tr = trajectory(position=moving_x, q=lambda t: np.stack([t, -t], axis=1))
    r = evaluate(Outcome.final_pose("end", point=(2.0, 0.3)), tr)
    assert r.value == pytest.approx(0.3, abs=1e-15) and r.success is None
    r = evaluate(Outcome.final_pose("end", point=(2.0, 0.3), within=0.2), tr)
    assert r.success is False
    r = evaluate(Outcome.final_pose("q", joints=["j0", "j1"], targets=[2.0, -1.0], within=1.0), tr)
    assert r.value == pytest.approx(math.sqrt(0.5), abs=1e-15) and r.success is True
    assert r.unit == "rad"


def test_final_orientation_is_the_angle_of_the_rotation_between():
    tr = trajectory(yaw=lambda t: 0.25 * t)  # ends turned 0.5 rad about z
    r = evaluate(Outcome.final_pose("facing", orientation=(0, 0, 0, 1), within=0.4), tr)
    assert r.value == pytest.approx(0.5, abs=1e-12) and r.success is False
    assert r.unit == "rad"
    # q and -q are the same orientation
    r = evaluate(Outcome.final_pose("facing", orientation=tuple(-quat_z(0.5))), tr)
    assert r.value == pytest.approx(0.0, abs=1e-7)


def test_effort_is_the_sum_of_force_times_speed_over_the_steps():
    tr = trajectory(v=lambda t: np.stack([3 + 0 * t, -2 + 0 * t], axis=1))
    b = tr.bodies["bot"]
    b.joint_forces[:] = [2.0, 5.0]  # joint 1 brakes: power -10 W, counted as 10
    b.joint_forces[0] = 1e9  # row 0 ends no step: not counted
    r = evaluate(Outcome.effort("work"), tr)
    assert r.value == (6.0 + 10.0) * 16 * DT == 32.0 and r.unit == "J"
    j0 = evaluate(Outcome.effort("j0", joints=["j0"], max=10.0), tr)
    assert j0 == OutcomeRecord("j0", "effort", "J", 12.0, False)
    assert j0.to_dict() == {
        "name": "j0",
        "kind": "effort",
        "unit": "J",
        "value": 12.0,
        "success": False,
    }


def farthest_x(trajectory, scale=1.0):
    """An outcome function of this module: the largest x reached, scaled."""
    return float(trajectory.body.base_position[:, 0].max() * scale)


def test_a_function_of_the_trajectory():
    tr = trajectory(position=moving_x)
    r = evaluate(
        Outcome.function_of("far", farthest_x, params={"scale": 2.0}, min=3.0, unit="m"), tr
    )
    assert r.value == 4.0 and r.success is True and r.unit == "m"
    r = evaluate(Outcome.function_of("plain", farthest_x), tr)
    assert r.value == 2.0 and r.success is None


def test_a_function_that_fails_or_returns_something_else(tmp_path):
    (tmp_path / "metrics.py").write_text(
        "def boom(tr):\n    raise KeyError('x')\n\ndef text(tr):\n    return 'fine'\n\n"
        "def yes(tr):\n    return True\n"
    )
    tr = trajectory()
    yes = evaluate(Outcome.function_of("y", "metrics.py:yes"), tr, base=tmp_path)
    assert yes.success is True and yes.value == 1.0
    with pytest.raises(ScenarioError, match=r"metrics.py:boom\(trajectory\) raised KeyError"):
        evaluate(Outcome.function_of("b", "metrics.py:boom"), tr, base=tmp_path, index=2)
    with pytest.raises(ScenarioError, match="returned 'fine'; expected a finite number"):
        evaluate(Outcome.function_of("t", "metrics.py:text"), tr, base=tmp_path)


def test_unknown_robot_link_or_joint_names_the_outcome_and_the_choices():
    tr = trajectory()
    with pytest.raises(ScenarioError, match=r"outcomes\[3\]\.link.*no link 'arm'; links: base, l0"):
        evaluate(Outcome.reach("x", (0, 0), 0.1, link="arm"), tr, index=3)
    with pytest.raises(ScenarioError, match=r"no movable joint 'knee'; movable joints: j0, j1"):
        evaluate(Outcome.track("x", joints=["knee"]), tr)
    with pytest.raises(ScenarioError, match=r"no robot 'other'"):
        evaluate(Outcome.upright("x", 0.1, robot="other"), tr)


# ---------------------------------------------------------------- records on disk


def _records(tr) -> dict[str, OutcomeRecord]:
    """One record of every shape: each kind's figures, none, a null figure, a note."""
    outcomes = [
        Outcome.reach("goal", (1.25, 0.0), 0.1),
        Outcome.upright("upright", 0.25),
        Outcome.track("q", joints=["j0"], targets=[0.0]),
        Outcome.effort("work", max=1.0),
        Outcome.reach("later", (1.0, 0.0), 0.1, phase="not run"),
    ]
    return {o.name: evaluate(o, tr) for o in outcomes}


def test_outcome_records_survive_a_saved_trajectory(tmp_path):
    tr = trajectory(position=moving_x, q=lambda t: np.stack([t, -t], axis=1))
    tr.outcomes = _records(tr)
    assert isinstance(tr.outcomes["goal"].figures, ReachFigures)
    assert isinstance(tr.outcomes["upright"].figures, UprightFigures)
    assert tr.outcomes["upright"].figures.exceeded_at is None  # a null figure
    assert isinstance(tr.outcomes["q"].figures, TrackFigures)
    assert tr.outcomes["work"].figures is None and tr.outcomes["later"].note
    back = Trajectory.load(tr.save(tmp_path / "run.npz"))
    assert back.outcomes == tr.outcomes
    assert list(back.outcomes) == list(tr.outcomes)
    # the JSON form keeps summary.json's key order: the common keys, the figures, the note
    assert list(tr.outcomes["goal"].to_dict()) == [
        "name", "kind", "unit", "value", "success", "closest", "final_distance"
    ]  # fmt: skip
    assert list(tr.outcomes["later"].to_dict())[-1] == "note"


def _save_with_record(tmp_path, name: str, record: dict) -> str:
    """A saved trajectory whose header holds ``record`` as outcome ``name``."""
    import json

    path = tmp_path / "run.npz"
    trajectory().save(path)
    with np.load(path) as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays["meta"]))
    meta["outcomes"] = {name: record}
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez_compressed(path, **arrays)
    return str(path)


GOAL = {"name": "goal", "kind": "reach", "unit": "s", "value": 1.0, "success": True}


@pytest.mark.parametrize(
    "record,key,message",
    [
        (
            {**GOAL, "closest": 0.0, "final_distance": 0.5, "colour": 1},
            "goal.colour",
            "unknown key",
        ),
        ({**GOAL, "exceeded_at": None}, "goal.exceeded_at", "closest, final_distance, note"),
        ({**GOAL, "closest": 0.0}, "goal.final_distance", "missing"),
        ({**GOAL, "value": "soon"}, "goal.value", "expected a number, got 'soon'"),
        ({**GOAL, "success": 1}, "goal.success", "expected true, false or null"),
        ({**GOAL, "kind": "win"}, "goal.kind", "unknown kind 'win'"),
        ({k: v for k, v in GOAL.items() if k != "unit"}, "goal.unit", "missing"),
        ({**GOAL, "name": "other"}, "goal.name", "named 'other'"),
    ],
)
def test_a_malformed_record_names_the_file_and_the_key(tmp_path, record, key, message):
    path = _save_with_record(tmp_path, "goal", record)
    with pytest.raises(TrajectoryFileError) as info:
        Trajectory.load(path)
    assert info.value.file == path and info.value.key == f"outcomes.{key}"
    assert message in str(info.value) and path in str(info.value)


def test_ensemble_members_carry_records_across_the_process_boundary():
    """A member pickles its records through their JSON form and reads them back equal."""
    import pickle

    from simbridge.compare.run.ensemble import Member

    records = _records(trajectory(position=moving_x, q=lambda t: np.stack([t, -t], axis=1)))
    m = Member(1, np.zeros((2, 3)), np.zeros(3), 0.5, records)
    state = m.__getstate__()
    assert state["outcomes"]["goal"] == records["goal"].to_dict()  # plain data on the wire
    back = pickle.loads(pickle.dumps(m))
    assert back.outcomes == records and back.index == 1


# ---------------------------------------------------------------- over an ensemble


def _wilson(k: int, n: int) -> tuple[float, float]:
    """Wilson's score interval by its formula (z for 95%)."""
    from scipy.stats import norm

    z = norm.ppf(0.975)
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return centre - half, centre + half


@pytest.mark.parametrize("k,n", [(9, 16), (0, 16), (16, 16), (1, 1), (3, 24)])
def test_success_rates_carry_wilson_intervals(k, n):
    low, high = success_interval(k, n)
    w_low, w_high = _wilson(k, n)
    assert low == pytest.approx(max(0.0, w_low), abs=1e-12)
    assert high == pytest.approx(min(1.0, w_high), abs=1e-12)
    assert 0 <= low <= k / n <= high <= 1
    if k == 0:
        assert low == 0.0 and high > 0.15  # 0/16 does not prove a rate of 0
    if k == n:
        assert high == 1.0 and low < 1.0


def test_summarize_counts_successes_and_describes_the_values():
    o = Outcome.reach("goal", (0, 0), 0.1)
    times = [6.0, 6.5, None, 7.0, None]
    records = [OutcomeRecord("goal", "reach", "s", v, v is not None) for v in times]
    s = outcome_stats_dict(summarize(o, records))
    assert s["success"]["successes"] == 3 and s["success"]["runs"] == 5
    assert s["success"]["rate"] == 0.6
    assert (s["success"]["low"], s["success"]["high"]) == success_interval(3, 5)
    assert s["value"] == {
        "runs": 3,
        "mean": 6.5,
        "std": 0.5,
        "min": 6.0,
        "median": 6.5,
        "max": 7.0,
    }
    assert s["nominal"]["value"] == 6.0 and len(s["runs"]) == 5
    # no bound: no success rate
    e = outcome_stats_dict(
        summarize(Outcome.effort("w"), [OutcomeRecord("w", "effort", "J", 1.0, None)])
    )
    assert e["success"] is None and e["value"]["std"] == 0.0


def _summary() -> dict:
    goal = Outcome.reach("reaches the goal", (0, 2), 0.05)
    work = Outcome.effort("work")

    def recs(o, values, ok):
        return [
            OutcomeRecord(o.name, o.kind, o.unit, v, s) for v, s in zip(values, ok, strict=True)
        ]

    engines = {
        "pybullet": {
            goal.name: outcome_stats_dict(summarize(goal, recs(goal, [6.0, 6.2], [True, True]))),
            work.name: outcome_stats_dict(summarize(work, recs(work, [10.0, 12.0], [None, None]))),
        },
        "mujoco": {
            goal.name: outcome_stats_dict(summarize(goal, recs(goal, [None, 8.0], [False, True]))),
            work.name: outcome_stats_dict(summarize(work, recs(work, [20.0, 20.0], [None, None]))),
        },
    }
    return {
        "outcomes": {
            "declared": [goal.to_dict(), work.to_dict()],
            "closed_loop": True,
            "confidence": 0.95,
            "method": "wilson",
            "engines": engines,
        }
    }


def test_the_headline_leads_with_counts_intervals_and_values():
    lines = outcome_lines(_summary())
    lo, hi = success_interval(2, 2)
    lo1, hi1 = success_interval(1, 2)
    assert lines[0] == (
        f"**reaches the goal**: reached in 2/2 runs on pybullet [{lo * 100:.0f}%, "
        f"{hi * 100:.0f}%], 1/2 runs on mujoco [{lo1 * 100:.0f}%, {hi1 * 100:.0f}%]; time to "
        "reach: 6.1 ± 0.14 s on pybullet, 8 s (1 run of 2) on mujoco."
    )
    assert lines[1] == "**work**: effort 11 ± 1.4 J on pybullet against 20 ± 0 J on mujoco."
    assert outcome_lines({"outcomes": None}) == []


def test_the_report_names_outcomes_that_change_at_half_the_time_step():
    s = _summary()
    nominal = s["outcomes"]["engines"]["pybullet"]["reaches the goal"]["nominal"]
    s["outcomes"]["half_timestep"] = {
        "pybullet": {"reaches the goal": {**nominal, "value": None, "success": False}},
        "mujoco": {},
    }
    lines = outcomes_section(s)
    assert (
        "At half the time step (each engine's own-error run) the nominal run's outcome changes: "
        "reaches the goal on pybullet succeeds (6 s) at dt, fails at dt/2." in lines
    )


def test_the_report_section_has_a_row_per_outcome_and_engine():
    lines = outcomes_section(_summary())
    assert lines[0] == "## Outcomes"
    rows = [x for x in lines if x.startswith("| reaches") or x.startswith("| work")]
    assert len(rows) == 4
    assert rows[1].startswith("| reaches the goal (time to reach) | mujoco | 1/2 | 50% [")
    # mean (one run), median, range, then the nominal run, which never reached it
    assert rows[1].endswith("| 8 s (1 run of 2) | 8 s | 8 s – 8 s | none |")
    assert rows[3].endswith("| 20 ± 0 J | 20 J | 20 J – 20 J | 20 J |")


# ---------------------------------------------------------------- in scenario files

SCENARIO = """\
name = "o"
[[robots]]
name = "pendulum"
urdf = "pendulum.urdf"
fixed_base = true
[[phases]]
name = "swing"
steps = 10
"""


def test_outcomes_are_read_and_written_back():
    text = SCENARIO + textwrap.dedent(
        """
        [[outcomes]]
        name = "bob reaches"
        kind = "reach"
        link = "bob"
        point = [0.5, 0.0, 0.5]
        within = 0.02
        hold = true
        by = 1.5
        phase = "swing"

        [[outcomes]]
        name = "still"
        kind = "upright"
        max_tilt = 0.1

        [[outcomes]]
        name = "hinge"
        kind = "track"
        joints = ["hinge"]
        targets = [0.3]
        max = 0.2

        [[outcomes]]
        name = "where"
        kind = "final_pose"
        joints = "hinge"
        targets = 0.0
        within = 0.5

        [[outcomes]]
        name = "work"
        kind = "effort"

        [[outcomes]]
        name = "facing"
        kind = "final_pose"
        orientation = [0.0, 0.0, 0.0, 1.0]
        """
    )
    sc = loads_scenario(text)
    kinds = ["reach", "upright", "track", "final_pose", "effort", "final_pose"]
    assert [o.kind for o in sc.outcomes] == kinds
    assert sc.outcomes[5].orientation == (0.0, 0.0, 0.0, 1.0)
    reach = sc.outcomes[0]
    assert (reach.link, reach.point, reach.within, reach.hold, reach.by) == (
        "bob",
        (0.5, 0.0, 0.5),
        0.02,
        True,
        1.5,
    )
    assert sc.outcomes[3].joints == ("hinge",) and sc.outcomes[3].targets == (0.0,)
    assert loads_scenario(dumps_scenario(sc)) == sc


@pytest.mark.parametrize(
    "table,key,message",
    [
        ('kind = "win"', "outcomes[0].kind", "expected one of reach, upright"),
        ('kind = "reach"\nwithin = 0.1', "outcomes[0].point", "missing (required by reach)"),
        ('kind = "reach"\npoint = [1]\nwithin = 0.1', "outcomes[0].point", "expected 2 (x, y)"),
        ('kind = "reach"\npoint = [1, 2]\nwithin = -1', "outcomes[0].within", "must be > 0"),
        ('kind = "upright"\nmax_tilt = 0.1\nrobot = "r2"', "outcomes[0].robot", "no robot 'r2'"),
        ('kind = "upright"\nmax_tilt = 0.1\nphase = "x"', "outcomes[0].phase", "no phase 'x'"),
        ('kind = "upright"\nmax_tilt = 0.1\npoint = [1, 2]', "outcomes[0].point", "unknown key"),
        ('kind = "final_pose"', "outcomes[0]", "one of point"),
        ('kind = "final_pose"\norientation = [0, 0, 0, 2]', "outcomes[0].orientation", "unit"),
        ('kind = "track"\nlink = "bob"', "outcomes[0].link", "needs points"),
        ('kind = "track"\nquantity = "force"', "outcomes[0].quantity", "position or velocity"),
        ('kind = "function"\nfunction = "nowhere.py:f"', "outcomes[0].function", "no such file"),
    ],
)
def test_bad_outcome_tables_name_the_key_and_line(table, key, message):
    text = SCENARIO + '\n[[outcomes]]\nname = "x"\n' + table + "\n"
    with pytest.raises(ScenarioError) as info:
        loads_scenario(text, file="o.toml")
    assert info.value.key == key and message in str(info.value)
    assert info.value.line is not None and info.value.line >= 10


def test_outcome_names_are_unique():
    text = SCENARIO + '\n[[outcomes]]\nname = "x"\nkind = "effort"\n' * 2
    with pytest.raises(ScenarioError, match="outcome name 'x' is used twice"):
        loads_scenario(text)


def test_quat_helpers_agree_with_tilt():
    assert tilt(np.stack([quat_z(0.0), quat_x(0.3)]))[1] == pytest.approx(0.3, abs=1e-12)


def test_one_quaternion_rotation_in_compare():
    """The tilt of the upright outcome rotates with run/quantities.py's ``rotate``, the one
    definition in compare/ (run/outcomes.py had a copy)."""
    import ast
    from pathlib import Path

    import simbridge.compare as package

    root = Path(package.__file__).parent
    found = [
        f"{path.relative_to(root)}:{node.name}"
        for path in sorted(root.rglob("*.py"))
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
        if isinstance(node, ast.FunctionDef) and node.name.lstrip("_") == "rotate"
    ]
    assert found == ["run/quantities.py:rotate"]


# ---------------------------------------------------------------- a run cut short


def test_truncated_says_where_it_cut():
    from simbridge.compare import load_scenario

    sc = load_scenario("kuka-reach")  # three phases of 2 s
    assert sc.cut_at is None
    assert sc.truncated(1.0).cut_at == 1.0
    assert sc.truncated(3.0).with_timestep(1 / 480).cut_at == 3.0
    assert sc.truncated(100.0).cut_at is None  # nothing cut


def test_a_cut_run_says_what_it_could_not_measure(tmp_path):
    (tmp_path / "metrics.py").write_text(
        "def late(tr):\n    return float('nan')\n\ndef index(tr):\n    return tr.time[99]\n"
    )
    tr = trajectory(position=moving_x, phases=[("a", 0, 8), ("b", 8, 16)])
    gone = evaluate(Outcome.reach("in c", (1.0, 0.0), 0.1, phase="c"), tr, cut_at=2.0)
    assert gone.value is None and gone.success is None and gone.figures is None
    assert gone.note == "phase 'c' was not run (the run was cut at 2 s)"
    late = Outcome.function_of("late", "metrics.py:late", max=1.0)
    r = evaluate(late, tr, base=tmp_path, cut_at=2.0)
    assert (r.value, r.success) == (None, None)
    assert r.note == "not evaluable on the run cut at 2 s: metrics.py:late(trajectory) returned nan"
    r = evaluate(Outcome.function_of("i", "metrics.py:index"), tr, base=tmp_path, cut_at=2.0)
    assert r.note.endswith("metrics.py:index(trajectory) raised IndexError: " + _index_error())
    # on a whole run the same function is an error in the scenario
    with pytest.raises(ScenarioError, match="returned nan; expected a finite number"):
        evaluate(late, tr, base=tmp_path)
    # what ran is measured: a reach on the whole (cut) run
    assert evaluate(Outcome.reach("goal", (1.25, 0.0), 0.1), tr, cut_at=2.0).value == 1.25


def _index_error() -> str:
    try:
        np.zeros(17)[99]
    except IndexError as exc:
        return str(exc)
    raise AssertionError


def test_the_headline_says_an_outcome_was_not_evaluated():
    goal = Outcome.reach("later", (0, 2), 0.05, phase="b")
    note = "phase 'b' was not run (the run was cut at 1 s)"
    rec = OutcomeRecord(goal.name, goal.kind, goal.unit, None, None, note=note)
    summary = {
        "outcomes": {
            "declared": [goal.to_dict()],
            "confidence": 0.95,
            "engines": {
                label: {goal.name: outcome_stats_dict(summarize(goal, [rec, rec]))}
                for label in ("pybullet", "mujoco")
            },
        }
    }
    assert outcome_lines(summary) == [f"**later**: not evaluated: {note}."]
    rows = [x for x in outcomes_section(summary) if x.startswith("| later")]
    assert rows and all(x.endswith(f"| not evaluated: {note} |") for x in rows)
