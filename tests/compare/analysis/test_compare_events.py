"""Where the gap is born: events on hand-made trajectories with known contacts, poses, joints
and motor forces (exact times and figures), the parting rule, and the ranking of parts."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _synthetic import quat_x, quat_z, trajectory

from simbridge.compare import diff
from simbridge.compare.analysis.events import KINDS, EngineEvents, Event, find_events, parting
from simbridge.compare.analysis.parts import THRESHOLDS, rank_parts
from simbridge.compare.report.events import event_words, parting_words
from simbridge.compare.report.parts import parts_words
from simbridge.compare.report.summary_json import event_dict, part_dict, parting_dict
from simbridge.compare.run.quantities import DEG, tilt_from

DT = 0.01  # bridge: ceil(0.05 / 0.01) = 5 rows


def _with_ground(tr, touching_rows):
    """Give ``tr``'s robot contacts on link 1 (``l0``) at ``touching_rows`` (10 N each) and add a
    ground body touching at the same rows."""
    body = tr.body
    n = len(tr.time)
    counts = np.zeros((n, 2), dtype=np.int32)
    counts[touching_rows, 1] = 1
    body.contact_counts = counts
    body.contact_normal_forces = counts * 10.0
    ground = type(body)(**{**body.__dict__, "name": "ground", "fixed_base": True})
    ground.contact_counts = counts[:, :1].copy() + counts[:, 1:]
    ground.contact_normal_forces = ground.contact_counts * 10.0
    tr.bodies["ground"] = ground
    return tr


def _contact_run():
    rows = np.zeros(101, dtype=bool)
    rows[1:21] = True  # touching from the first step
    rows[23:41] = True  # rows 21-22: a 2-row gap, bridged
    rows[61:101] = True  # rows 41-60 in the air: 20 rows
    rows[[70, 72, 74]] = False  # three one-row losses, 2 rows apart: chatter

    def z(t):  # flight from row 41 to 60, highest (1.5 m) at row 50
        rise = np.where((t > 0.405) & (t < 0.605), 1.5 - 150.0 * (t - 0.5) ** 2, 0.0)
        return np.stack([np.zeros_like(t), np.zeros_like(t), 0.1 + np.maximum(rise, 0)], axis=1)

    tr = trajectory(dt=DT, steps=100, position=z)
    return _with_ground(tr, rows)


def test_contact_airborne_peak_and_chatter_events():
    tr = _contact_run()
    e = find_events(tr, label="A")
    assert e.initial_contacts == ["l0"]
    got = [(x.kind, x.row, x.part) for x in e.events]
    assert got == [
        ("airborne", 41, None),
        ("contact_lost", 41, "l0"),
        ("peak_height", 50, None),
        ("contact_made", 61, "l0"),
        ("contact_chatter", 70, "l0"),
    ]
    air, lost, peak, made, chatter = e.events
    assert air.time == pytest.approx(0.41) and air.end == pytest.approx(0.60)
    assert air.figures["duration"] == pytest.approx(0.20)
    assert lost.others == ("ground",) and made.others == ("ground",)
    assert made.figures["normal_force"] == 10.0
    assert peak.figures["height"] == pytest.approx(1.6)
    assert peak.figures["rise"] == pytest.approx(1.5)
    assert chatter.end == pytest.approx(0.74)  # the last instant without contact
    assert chatter.figures == {"losses": 3.0, "duration": pytest.approx(0.05)}
    assert [x.phase for x in e.events] == ["all"] * 5
    assert e.counts()["contact_made"] == 1 and sum(e.counts().values()) == 5
    assert event_words(event_dict(lost), "A") == "A's bot lost contact with ground at l0"
    assert event_words(event_dict(made), "A") == "A's bot touched ground with l0"


def test_a_robot_that_never_touches_is_not_airborne_and_no_record_no_contact_event():
    tr = trajectory(dt=DT, steps=40)
    tr = _with_ground(tr, np.zeros(41, dtype=bool))
    assert find_events(tr).events == []
    tr.body.contact_counts = tr.body.contact_normal_forces = None
    e = find_events(tr)
    assert e.events == [] and not e.has_contacts


def test_tipped_over_measured_from_a_y_up_spawn():
    # spawned turned +90 deg about x (a y-up URDF standing); then turned a further
    # a(t) = 100 deg/s * t about world x up to 80 deg at row 80, and back to 0 at row 100
    def orientation(t):
        a = np.where(t <= 0.8 + 1e-9, 100.0 * t, 400.0 * (1.0 - t)) * DEG + math.pi / 2
        return np.stack([np.sin(a / 2), 0 * a, 0 * a, np.cos(a / 2)], axis=1)  # about x

    tr = trajectory(dt=DT, steps=100, orientation=orientation)
    tilt = tilt_from(tr.body.base_orientation, tr.body.base_orientation[0])
    assert tilt[0] == pytest.approx(0.0, abs=1e-12)
    assert tilt[80] == pytest.approx(80 * DEG)
    (tip,) = find_events(tr).events
    assert tip.kind == "tipped_over" and tip.row == 46  # the first row past 45 deg
    assert tip.end == pytest.approx(0.88)  # 400 * (1 - 0.88) = 48 deg; row 89: 44 deg
    assert tip.figures["tilt"] == pytest.approx(80 * DEG)


def test_a_y_up_robot_turning_in_place_never_tips_over():
    # spawned y-up (the body's z axis lies flat: 90 deg from world z), then yawing 2 turns
    def orientation(t):
        yaw = 4 * math.pi * t
        qz = quat_z(yaw)
        qx = quat_x(math.pi / 2)
        # qz * qx
        x1, y1, z1, w1 = np.moveaxis(qz, -1, 0)
        x2, y2, z2, w2 = qx
        return np.stack(
            [
                w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
                w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            ],
            axis=-1,
        )

    tr = trajectory(dt=DT, steps=100, orientation=orientation)
    assert np.abs(tilt_from(tr.body.base_orientation, tr.body.base_orientation[0])).max() < 1e-7
    assert find_events(tr).events == []
    d = diff(tr, tr)
    assert d.final_pose["a"].tilt == pytest.approx(90 * DEG)  # from world z: on its side
    assert d.final_pose["a"].tilt_from_spawn == pytest.approx(0.0, abs=1e-7)


def test_tilt_follows_gravity_not_z():
    # gravity along -y: the up is +y; a body turned 30 deg about z tilts 30 deg from it
    tr = trajectory(dt=DT, steps=4, yaw=lambda t: np.where(t > 0, 30 * DEG, 0.0))
    tr.manifest = {"profile": {"gravity": [0.0, -9.8, 0.0]}}
    tilt = tilt_from(tr.body.base_orientation, tr.body.base_orientation[0], (0.0, 1.0, 0.0))
    assert tilt[-1] == pytest.approx(30 * DEG)
    assert list(find_events(tr).up) == [0.0, 1.0, 0.0]


def test_joint_limit_events_and_a_joint_resting_at_its_limit_from_the_start():
    def q(t):
        j0 = np.where(t <= 0.05 + 1e-9, -1.0, np.minimum(1.0005, -1.0 + 10.0 * (t - 0.05)))
        j0 = np.where(t >= 0.5 - 1e-9, 0.0, j0)  # back off the limit at row 50
        return np.stack([j0, np.full_like(t, 5.0)], axis=1)

    tr = trajectory(dt=DT, steps=60, q=q)
    tr.body.joint_limits = np.array([[-1.0, 1.0], [np.nan, np.nan]])  # j1: no limit
    e = find_events(tr)
    (start,) = e.initial_limits
    assert (start.joint, start.side, start.end) == ("j0", "lower", pytest.approx(0.05))
    (hit,) = e.events
    # -1 + 10 (t - 0.05) >= 1 - 1e-3 first at t = 0.2499 -> row 25
    assert (hit.kind, hit.part, hit.side, hit.row) == ("joint_limit", "j0", "upper", 25)
    assert hit.end == pytest.approx(0.49)
    assert hit.figures == {"limit": 1.0, "beyond": pytest.approx(0.0005)}


def test_motor_saturated_at_max_force():
    def force(n):
        f = np.zeros((n, 2))
        f[20:30, 1] = -10.0
        f[25, 1] = -9.995  # within 1e-3 of max_force: still saturated
        f[40, 1] = 9.98  # 2e-3 short: not saturated
        f[50, 0] = 99.0  # no command on joint 0: nothing to saturate
        return f

    tr = trajectory(dt=DT, steps=60)
    body = tr.body
    body.joint_forces = force(61)
    mf = np.full((61, 2), np.nan)
    mf[1:, 1] = 10.0
    body.joint_max_forces = mf
    (sat,) = find_events(tr).events
    assert (sat.kind, sat.part, sat.row) == ("motor_saturated", "j1", 20)
    assert sat.end == pytest.approx(0.29)
    assert sat.figures == {"max_force": 10.0, "duration": pytest.approx(0.10)}
    assert "j1 motor saturated at its max_force 10" in event_words(event_dict(sat), "A")


# ---------------------------------------------------------------- parting


def _engine(label, *events):
    return EngineEvents(
        label=label,
        body="bot",
        events=list(events),
        up=np.array([0.0, 0.0, 1.0]),
        spawn=np.array([0.0, 0.0, 0.0, 1.0]),
        initial_contacts=[],
        has_contacts=True,
    )


PHASES = [("settle", 0.0, 1.0), ("turn", 1.0, 2.0)]


def test_parting_names_the_recent_event_then_the_ongoing_one_then_the_last_one():
    lost = Event("contact_lost", 1.20, 120, "turn", "bot", part="wheel", others=("plane",))
    air = Event("airborne", 0.50, 50, "settle", "bot", end=None, figures={"duration": 2.0})
    old = Event(
        "motor_saturated",
        0.30,
        30,
        "settle",
        "bot",
        part="j0",
        end=0.30,
        figures={"max_force": 5.0, "duration": 0.01},
    )
    a, b = _engine("A", old, lost), _engine("B", air)
    p = parting_dict(parting(1.25, 0.01, "base_distance", PHASES, [a, b], step=0.01))
    assert p["phase"] == "turn" and p["relation"] == "after"
    assert p["event"]["label"] == "A" and p["event"]["kind"] == "contact_lost"
    assert p["since"] == pytest.approx(0.05)
    assert [o["kind"] for o in p["ongoing"]] == ["airborne"]
    assert parting_words(p) == (
        "during 'turn', 0.050 s after A's bot lost contact with plane at wheel"
    )
    # 0.3 s later the contact loss is no longer recent: the flight going on is named
    p = parting_dict(parting(1.55, 0.01, "base_distance", PHASES, [a, b], step=0.01))
    assert p["relation"] == "during" and p["event"]["kind"] == "airborne"
    assert parting_words(p) == (
        "during 'turn', while B's bot left the ground (airborne for 2 s, from t = 0.500 s)"
    )
    # without the flight: the latest event, however old
    p = parting_dict(parting(1.55, 0.01, "base_distance", PHASES, [a], step=0.01))
    assert p["relation"] == "after" and p["event"]["kind"] == "contact_lost"
    assert p["since"] == pytest.approx(0.35)
    # an event in the very step that parts them counts; one after it does not
    p = parting_dict(parting(1.195, 0.01, "base_distance", PHASES, [a], step=0.01))
    assert p["event"]["kind"] == "contact_lost" and p["since"] < 0
    assert parting_words(p).startswith("during 'turn', in the same step as A's bot lost")
    # the event stamped one whole step after the parting: said so, not "in the same step"
    p = parting_dict(parting(1.19, 0.01, "base_distance", PHASES, [a], step=0.01))
    assert p["event"]["kind"] == "contact_lost" and p["since"] == pytest.approx(-0.01)
    assert parting_words(p).startswith("during 'turn', 0.010 s before A's bot lost")
    p = parting_dict(parting(1.0, 0.01, "base_distance", PHASES, [a], step=0.01))
    assert p["phase"] == "settle"  # at the boundary: the phase that led to it
    assert p["event"]["kind"] == "motor_saturated"


def test_parting_never_and_before_any_event():
    assert (
        parting_dict(parting(None, 0.01, "base_distance", PHASES, [_engine("A")]))["phase"] is None
    )
    assert (
        parting_words(parting_dict(parting(None, 0.01, "base_distance", PHASES, [_engine("A")])))
        == ""
    )
    e = _engine("A")
    p = parting_dict(parting(0.5, 0.01, "base_distance", PHASES, [e]))
    assert (
        p["event"] is None
        and parting_words(p) == "during 'settle', before any event of either engine"
    )
    e.initial_contacts = ["base", "wheel"]
    p = parting_dict(parting(0.01, 0.01, "base_distance", PHASES, [e], step=0.01))
    assert p["initial_contacts"] == {"A": ["base", "wheel"]}
    assert parting_words(p) == (
        "during 'settle', in the first step, with bot touching something from its first step "
        "at base, wheel (A)"
    )


def test_every_kind_has_words():
    for kind in KINDS:
        e = Event(
            kind,
            0.1,
            10,
            "p",
            "bot",
            part="x",
            side="upper",
            others=("plane",),
            figures={
                "normal_force": 1,
                "duration": 1,
                "height": 1,
                "rise": 1,
                "tilt": 1,
                "limit": 1,
                "beyond": 0,
                "max_force": 1,
                "losses": 3,
            },
        )
        assert not event_words(event_dict(e), "A").endswith(kind)


# ---------------------------------------------------------------- ranking


def test_parts_ranked_by_when_and_how_far():
    # j0 drifts 0.1 deg per step from t = 0; j1 jumps 3 deg at t = 0.5; the base moves apart by
    # 2 mm per step from t = 0 (links base and l0 alike: l0 sits 1 m above the base)
    a = trajectory(dt=DT, steps=100)
    b = trajectory(
        dt=DT,
        steps=100,
        q=lambda t: np.stack(
            [np.rint(t / DT) * 0.1 * DEG, np.where(t >= 0.5 - 1e-9, 3 * DEG, 0)], axis=1
        ),
        position=lambda t: np.stack([0.2 * t, 0 * t, 0 * t], 1),
    )
    parts = rank_parts(diff(a, b))
    assert [(p.kind, p.name) for p in parts] == [
        ("link", "base"),  # 1 cm at row 5
        ("link", "l0"),  # at row 5 too, as far: in the record's order
        ("joint", "j0"),  # 1 deg at row 10
        ("joint", "j1"),  # 3 deg at row 50
    ]
    base, _, j0, j1 = parts
    assert j0.first == pytest.approx(0.10) and j0.largest == pytest.approx(10 * DEG)
    assert j0.threshold == THRESHOLDS["rad"] and j0.unit == "rad"
    assert base.first == pytest.approx(0.05) and base.largest == pytest.approx(0.2)
    assert base.largest_at == pytest.approx(1.0) and base.at_end == pytest.approx(0.2)
    assert base.threshold == THRESHOLDS["m"] == 0.01 and base.unit == "m"
    assert (j1.name, j1.first, j1.largest) == ("j1", pytest.approx(0.5), pytest.approx(3 * DEG))
    words = parts_words([part_dict(p) for p in parts])
    assert words.startswith("The first part to come apart is ")
    assert words.endswith("(of 4 joints and links).")


def test_parts_that_never_part_rank_by_their_gap_over_the_threshold():
    a = trajectory(dt=DT, steps=10)
    b = trajectory(
        dt=DT,
        steps=10,
        q=lambda t: np.stack([0 * t + 0.5 * DEG, 0 * t + 0.1 * DEG], 1),
        position=lambda t: np.stack([0 * t + 0.002, 0 * t, 0 * t], 1),
    )
    parts = rank_parts(diff(a, b))
    assert [p.name for p in parts] == ["j0", "base", "l0", "j1"]  # 0.5, 0.2, 0.2, 0.1
    assert all(p.first is None for p in parts)
    assert parts_words([part_dict(p) for p in parts]) == (
        "No joint or link comes 1° or 1 cm apart; the nearest to it is joint `j0` "
        "(largest gap 0.5° at t = 0.000 s)."
    )


def test_held_commands_carry_velocity_and_position_targets_until_replaced():
    from simbridge.compare.report.plots import held_commands

    modes = np.array([0, 0, 2, 2, 0, 0, 3, 0, 1, 0])
    targets = np.array([np.nan, np.nan, 1, 2, np.nan, np.nan, 5, np.nan, 7, np.nan])
    m, t = held_commands(modes, targets)
    assert m.tolist() == [0, 0, 2, 2, 2, 2, 3, 0, 1, 1]  # a torque command is not held
    np.testing.assert_array_equal(t, [np.nan, np.nan, 1, 2, 2, 2, 5, np.nan, 7, 7])
