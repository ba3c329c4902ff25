"""What happens to the robot, in one line of the headline and of report.md's opening: the depth a
robot starts inside something (recorded per link and step), the engines' throws, and the gap's
time-step share beside a chaotic verdict."""

from __future__ import annotations

import copy
from dataclasses import replace

import pytest

from simbridge.compare import compare, load_scenario, run
from simbridge.compare.report import brief, headline, summary
from simbridge.compare.report.story import START_DEPTH, THROW, story_words
from simbridge.compare.report.verdict import pair_words, time_step_share
from simbridge.compare.run.events import find_events


def _lifted(z: float):
    """r2d2 as the tutorial drops it, spawned at height ``z``."""
    sc = load_scenario("r2d2")
    robots = tuple(replace(r, position=(0.0, 0.0, z)) if r.name == "r2d2" else r for r in sc.robots)
    return replace(sc, robots=robots)


def test_the_start_depth_is_how_far_the_spawn_pose_reaches_into_the_ground(backend):
    low = find_events(run(_lifted(0.1), backend, duration=0.05)).start_depth
    high = find_events(run(_lifted(0.3), backend, duration=0.05)).start_depth
    assert low is not None and high is not None
    assert low.others == ("plane",) and low.depth > START_DEPTH
    # raised 0.2 m, it starts 0.2 m less deep (within PhysX's float32 and the contact margins)
    assert low.depth - high.depth == pytest.approx(0.2, abs=1e-3)
    # resting on its wheels (r2d2-gentle spawns it there): not inside anything by 1 cm
    rest = find_events(run("r2d2-gentle", backend, duration=0.05)).start_depth
    assert rest is None or rest.depth < START_DEPTH


def _events(depth=None, peaks=(), tipped=None):
    """``summary.json``'s ``events.<engine>`` with only what story_words reads."""
    events = [
        {"kind": "peak_height", "time": 1.0, "figures": {"height": h, "rise": r}} for h, r in peaks
    ]
    if tipped is not None:
        events.append({"kind": "tipped_over", "time": tipped, "figures": {"tilt": 1.6}})
    start = None if depth is None else {"link": "left_leg", "depth": depth, "others": ["plane"]}
    return {"body": "bot", "start_depth": start, "events": events}


def test_the_story_names_the_start_and_each_engines_throw():
    s = {
        "labels": ["a", "b", "c"],
        "subject": "bot",
        "events": {
            "a": _events(0.371, [(2.426, 1.93), (0.45, 0.0)]),
            "b": _events(0.371, [(14.366, 13.88)]),
            "c": _events(0.371, [(0.5, THROW / 2)]),  # a hop, not a throw
        },
    }
    assert story_words(s) == (
        "bot starts 37.1 cm inside plane: a throws it to a height of 2.43 m, b to 14.37 m "
        "(c: no throw of 10.0 cm or more)."
    )
    s["events"] = {k: _events(START_DEPTH / 2, tipped=2.0 if k == "a" else None) for k in "abc"}
    assert story_words(s) == "bot tips over (a at t = 2.000 s); on b and c it stays upright."
    s["events"] = {k: _events() for k in "abc"}
    assert story_words(s) is None


@pytest.fixture(scope="module")
def r2d2():
    """r2d2 dropped into the ground, pybullet and mujoco, long enough for both throws to peak
    (pybullet's at t = 0.675 s) and for the gap to lie within an own time-step error."""
    c = compare("r2d2", ["pybullet", "mujoco"], duration=0.8, ensemble=3, workers=0)
    return summary(c)


@pytest.fixture(scope="module")
def pendulum():
    c = compare("pendulum", ["pybullet", "mujoco"], duration=0.5, ensemble=1, workers=0)
    return summary(c)


def test_the_headline_tells_a_drop_into_the_ground_and_not_a_quiet_run(r2d2, pendulum):
    lines = brief(r2d2, "r.md")
    story = story_words(r2d2)
    assert story is not None and story.startswith("r2d2 starts 37.1 cm inside plane: pybullet ")
    for label in ("pybullet", "mujoco"):
        peak = max(
            e["figures"]["height"]
            for e in r2d2["events"][label]["events"]
            if e["kind"] == "peak_height"
        )
        assert peak >= THROW and f"{label} " in story
    assert story in lines and len(lines) <= 6 and lines[-1] == "report: r.md"
    assert story in headline(r2d2)  # report.md's opening carries it too
    quiet = brief(pendulum, "r.md")
    assert story_words(pendulum) is None and len(quiet) == 3
    assert not any("inside" in x or "throws" in x or "tips over" in x for x in quiet)


def test_the_within_counts_are_each_engines_instants_counted_alone(r2d2):
    v = r2d2["verdict"]
    within, n = v["instants"]["within"], v["instants"]
    assert set(within) == {"pybullet", "mujoco"}
    apart = n["total"] - n["agree"]
    for w in within.values():
        assert 0 <= w["spread"] <= apart and 0 <= w["own_error"] <= apart
    # each class counts an instant once: chaotic at most where some spread covers it, unresolved
    # at most where some own error does
    assert n["chaotic"] <= sum(w["spread"] for w in within.values())
    assert n["unresolved"] <= sum(w["own_error"] for w in within.values())


def test_a_chaotic_verdict_carries_the_time_step_share_where_it_is_larger():
    v = {
        "verdict": "chaotic",
        "engines": ["a"],
        "instants": {
            "total": 981,
            "within": {
                "a": {"spread": 210, "own_error": 259},
                "b": {"spread": 0, "own_error": 980},
            },
        },
    }
    assert time_step_share(v) == (
        "the gap is at most 2x b's own time-step error at 980 of 981 instants (at most 2x a's "
        "spread at 210)"
    )
    v["instants"]["within"]["b"]["own_error"] = 100  # a's spread covers more: chaos alone
    v["instants"]["within"]["a"]["own_error"] = 200
    assert time_step_share(v) is None
    assert time_step_share({**v, "verdict": "unresolved"}) is None


def test_the_share_reaches_the_terminal_and_report_words(r2d2):
    # the short run is unresolved (within mujoco's own time-step error at every instant apart);
    # judged chaotic on pybullet's spread at its last 10 instants, it would carry the share
    s = copy.deepcopy(r2d2)
    v = s["verdict"]
    apart = v["instants"]["total"] - v["instants"]["agree"]
    assert v["instants"]["within"]["mujoco"]["own_error"] == apart
    v.update(verdict="chaotic", engines=["pybullet"], reason="within spread")
    v["instants"]["within"]["pybullet"]["spread"] = 10
    share = time_step_share(v)
    assert share == (
        f"the gap is at most 2x mujoco's own time-step error at {apart} of "
        f"{v['instants']['total']} instants (at most 2x pybullet's spread at 10)"
    )
    line = brief(s)[0]
    assert line.startswith("r2d2, pybullet against mujoco: CHAOTIC (pybullet")
    assert f"; {share}: at this time step the gap says nothing about the physics." in line
    assert pair_words({"labels": ["pybullet", "mujoco"], "verdict": v, "headline": {}}).endswith(
        f"; {share}"
    )
    assert share in " ".join(headline(s))  # report.md says which comes first, and why
    assert "Chaos is named first" in " ".join(headline(s))
