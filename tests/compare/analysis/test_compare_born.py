"""Where the gap is born and which part carries it, on real engines: a fixed KUKA under position
control pushed against a joint limit, a y-up quadruped standing and crouching
(tests/compare/data), r2d2-gentle, and the summary fields' documentation.

Measured (PyBullet 3.2.7, MuJoCo 4.0, 1/240 s): on kuka-limit both engines put
lbr_iiwa_joint_1 on its upper limit at t = 0.729 s and part nowhere (largest joint gap 0.12°);
laikago-crouch stands within 0.05° of its spawn orientation (its base z axis 90° from world
z), and the engines part during 'crouch' (1 cm at t = 0.600 s); on r2d2-gentle they part
during 'turn' (t = 1.267 s) while MuJoCo's wheels chatter on the plane (about 115 losses of
contact in 1 s, its hops).
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from simbridge.compare import compare, report
from simbridge.compare.analysis.events import KINDS
from simbridge.compare.report import summary as compare_summary
from simbridge.compare.report.parts import parts_words
from simbridge.compare.run.quantities import DEG

DATA = Path(__file__).parents[1] / "data"
DOCS = Path(__file__).resolve().parents[3] / "docs" / "compare.md"
PAIR = ["pybullet", "mujoco"]


def _written(tmp_path_factory, name):
    out = tmp_path_factory.mktemp(name)
    c = compare(DATA / f"{name}.toml", PAIR, ensemble=2, workers=0, resync_every=0)
    path = report(c, out, trajectories=False)
    return c, out, path.read_text(), json.loads((out / "summary.json").read_text())


@pytest.fixture(scope="module")
def kuka(tmp_path_factory):
    return _written(tmp_path_factory, "kuka-limit")


@pytest.fixture(scope="module")
def laikago(tmp_path_factory):
    return _written(tmp_path_factory, "laikago-crouch")


def _section(text, title):
    start = text.index(f"## {title}")
    end = text.find("\n## ", start + 1)
    return text[start:end]


# ---------------------------------------------------------------- a fixed arm


def test_fixed_arm_figures(kuka):
    c, out, text, s = kuka
    for name in ("height", "joints_position", "motors", "events", "paths", "distance"):
        assert (out / f"{name}.png").is_file(), name
        assert f"]({name}.png)" in text
    for name in ("heading", "joints_velocity", "joints_torque"):  # fixed base; position only
        assert not (out / f"{name}.png").exists(), name


def test_fixed_arm_reaches_its_limit_and_saturates_in_both_engines(kuka):
    c, out, text, s = kuka
    for label in c.labels:
        e = s["events"][label]
        assert e["contacts_recorded"] and e["initial_contacts"] == []
        assert e["counts"]["contact_made"] == e["counts"]["airborne"] == 0
        assert e["counts"]["tipped_over"] == 0  # a fixed base never tips
        (limit,) = [x for x in e["events"] if x["kind"] == "joint_limit"]
        assert (limit["part"], limit["side"], limit["phase"]) == (
            "lbr_iiwa_joint_1",
            "upper",
            "limit",
        )
        assert 0.70 < limit["time"] < 0.76  # measured 0.729 s on both
        assert limit["figures"]["limit"] == pytest.approx(2.96705972839)
        assert limit["end"] is None  # held there to the end
        sat = [x for x in e["events"] if x["kind"] == "motor_saturated"]
        assert any(x["part"] == "lbr_iiwa_joint_1" and x["phase"] == "limit" for x in sat)
        assert all(x["figures"]["max_force"] == 200.0 for x in sat)


def test_fixed_arm_parts_nowhere_and_says_so(kuka):
    c, out, text, s = kuka
    assert s["parting"]["time"] is None and s["parting"]["event"] is None
    parts = s["parts"]
    assert len(parts) == 7 + 8  # 7 joints; the base and 7 links
    assert all(p["first"] is None for p in parts)
    ratios = [p["largest"] / p["threshold"] for p in parts]
    assert ratios == sorted(ratios, reverse=True)
    words = parts_words(parts)
    assert words.startswith("No joint or link comes 1° or 1 cm apart; the nearest to it is ")
    assert words in s["headline"]["text"]
    assert "## Which part parts first" in text


def test_fixed_arm_departures_leave_contacts_out(kuka):
    c, out, text, s = kuka
    deps = s["departures"]["mujoco"]
    applied = {d["key"] for d in deps["apply"]}
    assert {"joint limits", "motors"} <= applied
    assert {"contact", "cylinder", "speed clamp"} <= set(deps["left_out"])
    limits = next(d for d in deps["apply"] if d["key"] == "joint limits")
    assert "lbr_iiwa_joint_1 (upper)" in limits["measured"]
    assert s["departures"]["pybullet"] == {"apply": [], "left_out": []}
    section = _section(text, "Profile departures that apply here")
    assert "r2d2" not in section and "`contact`" not in section.split("Left out")[0]


# ---------------------------------------------------------------- a y-up quadruped


def test_y_up_quadruped_standing_is_not_tipped_over(laikago):
    c, out, text, s = laikago
    for label in c.labels:
        assert s["events"][label]["counts"]["tipped_over"] == 0
    pose = s["cross"]["final_pose"]
    for side in ("a", "b"):
        assert pose[side]["tilt"] == pytest.approx(90 * DEG, abs=1 * DEG)  # z-up: on its side
        assert pose[side]["tilt_from_spawn"] < 0.2 * DEG  # as it stood at spawn
    final = _section(text, "Final poses")
    assert "tilt from its spawn orientation" in final and "tipped over" not in final


def test_y_up_quadruped_figures(laikago):
    c, out, text, s = laikago
    for name in ("height", "heading", "joints_position", "motors", "events"):
        assert (out / f"{name}.png").is_file(), name
    for name in ("joints_velocity", "joints_torque"):
        assert not (out / f"{name}.png").exists(), name


def test_y_up_quadruped_events_parting_and_parts(laikago):
    c, out, text, s = laikago
    for label in c.labels:
        e = s["events"][label]
        assert e["initial_contacts"] == []  # spawned with its toes 5 mm above the plane
        made = [x for x in e["events"] if x["kind"] == "contact_made"]
        assert made and made[0]["phase"] == "stand" and made[0]["others"] == ["plane"]
        assert {x["part"] for x in made} >= {"toeFR", "toeFL", "toeRR", "toeRL"}
        assert e["up"] == [0.0, 0.0, 1.0]
    p = s["parting"]
    assert p["phase"] == "crouch" and 0.5 < p["time"] < 0.7  # measured 0.600 s
    assert p["event"] is not None and p["event"]["time"] <= p["time"] + c.timestep
    born = s["headline"]["text"]
    assert any("The gap is born during 'crouch'" in line for line in born)
    parts = s["parts"]
    assert len(parts) == 12 + 17
    firsts = [x["first"] for x in parts if x["first"] is not None]
    assert firsts and firsts == sorted(firsts)
    assert parts[0]["first"] == min(firsts)
    assert parts_words(parts) in born
    table = _section(text, "Which part parts first")
    assert f"| 1 | {parts[0]['kind']} `{parts[0]['name']}` |" in table


def test_y_up_quadruped_departures_apply_with_its_own_figures(laikago):
    c, out, text, s = laikago
    deps = s["departures"]["mujoco"]
    contact = next(d for d in deps["apply"] if d["key"] == "contact")
    assert "laikago's base at the end of 'stand'" in contact["measured"]
    assert "r2d2" not in contact["text"] and "r2d2" not in contact["measured"]
    assert {"cylinder", "joint limits", "speed clamp"} <= set(deps["left_out"])
    section = _section(text, "Profile departures that apply here")
    assert "r2d2" not in section


# ---------------------------------------------------------------- r2d2-gentle, torque


def test_r2d2_gentle_parts_while_mujoco_chatters_in_the_turn():
    c = compare("r2d2-gentle", PAIR, ensemble=1, resync_every=0)
    s = compare_summary(c)
    p = s["parting"]
    assert p["phase"] == "turn" and p["relation"] == "during"
    e = p["event"]
    assert (e["label"], e["kind"], e["others"]) == ("mujoco", "contact_chatter", ["plane"])
    assert e["part"].endswith("_wheel") and e["figures"]["losses"] > 50
    assert s["events"]["pybullet"]["counts"]["contact_chatter"] == 0
    cyl = next(d for d in s["departures"]["mujoco"]["apply"] if d["key"] == "cylinder")
    assert "right_front_wheel" in cyl["why"]


def test_torque_commands_get_their_own_figure(tmp_path):
    c = compare("spinning-wheel", PAIR, ensemble=1, duration=1.5, resync_every=0)  # torque
    report(c, tmp_path, trajectories=False)
    for name in ("joints_velocity", "joints_torque", "height"):
        assert (tmp_path / f"{name}.png").is_file(), name
    assert not (tmp_path / "heading.png").exists()


# ---------------------------------------------------------------- docs


def test_every_born_summary_field_is_described_in_the_docs(laikago, kuka):
    docs = DOCS.read_text()
    keys = {"events", "parting", "parts", "departures"}
    for _, _, _, s in (laikago, kuka):
        for e in s["events"].values():
            keys |= set(e) | set(e["counts"])
            for x in e["events"]:
                keys |= set(x) | set(x["figures"])
            for x in e["initial_limits"]:
                keys |= set(x)
        keys |= set(s["parting"])
        for part in s["parts"]:
            keys |= set(part)
        for d in s["departures"].values():
            keys |= set(d)
            for x in d["apply"]:
                keys |= set(x)
    keys |= set(KINDS) | {"losses", "duration", "normal_force", "height", "rise", "tilt"}
    keys |= {"limit", "beyond", "max_force"}
    missing = sorted(k for k in keys if f"`{k}`" not in docs)
    assert not missing, f"docs/compare.md does not describe {missing}"
