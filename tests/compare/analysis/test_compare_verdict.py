"""The verdict on hand-made ensembles (no engine): exact spreads, gaps, ratios, p-values and the
choice among agree / differ / chaotic / unresolved."""

from __future__ import annotations

import math

import numpy as np
import pytest

from simbridge.compare.analysis.verdict import (
    FLOOR_RELATIVE,
    Segment,
    Verdict,
    energy_test,
    judge,
    precision_floor,
)
from simbridge.compare.report.summary_json import verdict_dict
from simbridge.compare.report.verdict import marginal_words, pair_words, verdict_lines
from simbridge.compare.run.ensemble import horizons, offsets, pairwise_spread, perturbed
from simbridge.compare.run.quantities import rotation_angle
from simbridge.compare.scenario import load_scenario

T = 3
TIME = np.array([0.0, 0.5, 1.0])


def cloud(xs, ys=None, *, t=T) -> np.ndarray:
    """(N, T, 3) members held at x = xs (y = ys) at every instant."""
    xs = np.asarray(xs, dtype=np.float64)
    ys = np.zeros_like(xs) if ys is None else np.asarray(ys, dtype=np.float64)
    pts = np.stack([xs, ys, np.zeros_like(xs)], axis=-1)
    return np.repeat(pts[:, None, :], t, axis=1)


def own(value: float) -> np.ndarray:
    return np.full(T, value)


def verdict(a, b, own_a=1e-3, own_b=1e-3, **kw) -> Verdict:
    return judge(TIME, "base_distance", ("A", "B"), [a, b], [own(own_a), own(own_b)], **kw)


def summary_of(v: Verdict, size: int) -> dict:
    return {
        "verdict": verdict_dict(v),
        "ensemble": {"perturbation": {"position": 1e-9, "orientation": 1e-9}, "size": size},
    }


def test_spread_is_the_90th_percentile_of_pairwise_distances():
    # pairwise distances of x = 0, 1, 2, 3: 1, 1, 1, 2, 2, 3; the 90th percentile
    # (linear) sits halfway between the 5th and 6th: 2.5
    assert pairwise_spread("base_distance", cloud([0, 1, 2, 3])).tolist() == [2.5] * T
    assert pairwise_spread("base_distance", cloud([5.0])).tolist() == [0.0] * T
    # joint RMS: two joints, members (0, 0) and (3, 4): RMS of (3, 4) = sqrt(12.5)
    q = np.array([[[0.0, 0.0]], [[3.0, 4.0]]])
    assert pairwise_spread("joint_position_rms", q)[0] == pytest.approx(math.sqrt(12.5))


def test_horizons_are_the_first_instants_reaching_each_threshold():
    t = np.arange(5) * 0.25
    s = np.array([0.0, 0.005, 0.01, 0.5, 2.0])
    assert horizons(t, s, (0.01, 0.1, 1.0, 10.0)) == [
        (0.01, 0.5),
        (0.1, 0.75),
        (1.0, 1.0),
        (10.0, None),
    ]


def test_offsets_have_the_size_asked_and_follow_the_seed():
    dpos, drot = offsets(6, 2, 1e-9, 2e-9, seed=3)
    assert dpos.shape == drot.shape == (6, 2, 3)
    assert not dpos[0].any() and not drot[0].any()  # member 0: the nominal run
    np.testing.assert_allclose(np.linalg.norm(dpos[1:], axis=-1), 1e-9, rtol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(drot[1:], axis=-1), 2e-9, rtol=1e-12)
    again = offsets(6, 2, 1e-9, 2e-9, seed=3)
    assert np.array_equal(again[0], dpos) and np.array_equal(again[1], drot)
    assert not np.array_equal(offsets(6, 2, 1e-9, 2e-9, seed=4)[0], dpos)


def test_perturbed_scenario_moves_every_spawn_pose_by_the_offset():
    sc = load_scenario("r2d2")
    dpos, drot = offsets(2, len(sc.robots), 1e-3, 1e-3, seed=0)
    moved = perturbed(sc, dpos[1], drot[1])
    for r, (before, after) in enumerate(zip(sc.robots, moved.robots, strict=True)):
        shift = np.subtract(after.position, before.position)
        np.testing.assert_allclose(shift, dpos[1, r], rtol=1e-9, atol=1e-15)
        angle = rotation_angle(np.array(before.orientation), np.array(after.orientation))
        assert angle == pytest.approx(1e-3, rel=1e-6)
    assert moved.phases == sc.phases
    assert perturbed(sc, dpos[0], drot[0]) == sc


def test_precision_floor_scales_with_the_recorded_magnitude():
    assert precision_floor([cloud([0.5])]) == FLOOR_RELATIVE  # at least 1e-12 of 1
    assert precision_floor([cloud([0.5]), cloud([-4000.0])]) == pytest.approx(4e-9)


def test_agree_when_the_gap_stays_below_the_tolerance():
    v = verdict(cloud([0.0, 1e-9]), cloud([2e-3, 2e-3 + 1e-9]))
    assert v.verdict == "agree" and not v.marginal and v.test is None
    assert v.tolerance == 0.01  # base distance: its first threshold, 1 cm
    assert v.max_gap[0] == pytest.approx(2e-3)
    close = verdict(cloud([0.0]), cloud([6e-3]))
    assert close.verdict == "agree" and close.marginal
    assert [marginal_words(m) for m in close.marginal_reasons] == [
        "the largest gap is 0.6x the tolerance"
    ]
    assert verdict_lines(summary_of(v, 2))[0].startswith("**A and B agree on this scenario**")


def test_differ_exact_figures():
    a = cloud(np.arange(4) * 1e-6)
    b = cloud(1.0 + np.arange(4) * 1e-6)
    v = verdict(a, b, own_a=1e-3, own_b=0.1)
    assert v.verdict == "differ" and v.engines == [] and not v.marginal
    assert v.judged_at == "end" and v.judged_index == T - 1
    # cross distances 1 + (j - i) 1e-6: the median of the 16 is 1
    assert v.gap.value == pytest.approx(1.0, abs=1e-12)
    assert v.gap.low <= v.gap.value <= v.gap.high
    ea, eb = v.per_engine
    assert ea.spread.value == pytest.approx(2.5e-6, rel=1e-9)
    assert ea.largest_pair == pytest.approx(3e-6, rel=1e-9)
    assert ea.gap_over_spread == pytest.approx(1 / 2.5e-6, rel=1e-6)
    assert eb.gap_over_own_error == pytest.approx(10.0, rel=1e-9)
    # 8 runs into two groups of 4: 70 splits; only the true one and its mirror are as far apart
    assert v.test is not None and v.test.exact and v.test.resamples == 70
    assert v.test.p_value == pytest.approx(2 / 70)
    words = verdict_lines(summary_of(v, 4))
    assert words[0].startswith("**A and B differ on this scenario**: their runs end a median")
    assert "p = 0.029" in words[1]


def test_chaotic_names_the_engine_whose_spread_covers_the_gap():
    a = cloud([-1, -1, -1, 1, 1])  # two clusters 2 m apart
    b = cloud([-1] * 5, [0.1] * 5)  # 10 cm beside the larger cluster
    v = verdict(a, b)
    assert v.verdict == "chaotic" and v.engines == ["A"] and not v.marginal
    # pairwise distances of A: four 0, six 2: the 90th percentile is 2
    assert v.per_engine[0].spread.value == pytest.approx(2.0)
    # 15 cross distances of 0.1 and 10 of sqrt(4.01): the median is 0.1
    assert v.gap.value == pytest.approx(0.1)
    assert v.per_engine[0].gap_over_spread == pytest.approx(0.05)
    assert v.per_engine[1].other_to_nearest == pytest.approx(0.1)  # A's runs to B's nearest
    words = verdict_lines(summary_of(v, 5))
    assert words[0].startswith("**A is chaotic on this scenario**: 5 runs started 1e-09 m")
    assert "at this scale A's outcome is not predictable" in words[1]


def test_a_gap_up_to_twice_a_spread_is_chaotic_and_marginal():
    a = cloud([0.0, 0.0, 0.0, 1.0, 1.0])  # spread 1 m
    b = cloud([1.5] * 5)
    v = verdict(a, b)
    # cross distances: 15 of 1.5, 10 of 0.5: median 1.5 = 1.5x A's spread
    assert v.gap.value == pytest.approx(1.5)
    assert v.verdict == "chaotic" and v.engines == ["A"] and v.marginal
    assert [marginal_words(m) for m in v.marginal_reasons] == ["the gap is 1.5x A's spread"]


def test_unresolved_when_the_gap_lies_within_an_own_time_step_error():
    a = cloud(np.arange(4) * 1e-6)
    b = cloud(1.0 + np.arange(4) * 1e-6)
    v = verdict(a, b, own_a=1e-3, own_b=1.2)
    assert v.verdict == "unresolved" and v.reason == "within own time-step error"
    assert v.engines == ["B"] and v.marginal  # 0.833x B's own error
    line = verdict_lines(summary_of(v, 4))[0]
    assert "which is within B's own time-step error (1.20 m between dt and dt/2)" in line
    assert "near 1" in line  # marginal: what the range means is said where it is used


def test_a_gap_above_the_own_error_is_near_it_never_within():
    """The gap 1.25x B's own error still covers it (a ratio up to 2 is near 1), but the words
    and the reason give the ratio, never "within"."""
    a = cloud(np.arange(4) * 1e-6)
    b = cloud(1.0 + np.arange(4) * 1e-6)
    v = verdict(a, b, own_a=1e-3, own_b=0.8)
    assert v.verdict == "unresolved" and v.reason == "near own time-step error"
    assert v.engines == ["B"] and v.marginal
    s = summary_of(v, 4)
    line = verdict_lines(s)[0]
    assert "within" not in line.split("apart", 1)[1]
    assert "which is 1.25x B's own time-step error (80.0 cm between dt and dt/2)" in line
    assert "not clearly larger (a ratio between 0.5x and 2x is near 1)" in line
    pair = {"labels": ["A", "B"], "verdict": s["verdict"], "headline": {}}
    assert "(1.25x B's own time-step error)" in pair_words(pair)


def test_unresolved_when_the_ensembles_are_not_separated_or_absent():
    # two runs each: 6 splits, p = 2/6 at best
    v = verdict(cloud([0.0, 1e-6]), cloud([1.0, 1.0 + 1e-6]))
    assert v.verdict == "unresolved" and v.reason == "not separated"
    assert v.test.p_value == pytest.approx(1 / 3)
    single = verdict(cloud([0.0]), cloud([1.0]))
    assert single.verdict == "unresolved" and single.reason == "single run"
    assert single.test is None and single.gap.low is None
    assert "--ensemble" in verdict_lines(summary_of(single, 1))[0]


def test_no_absurd_ratio_when_an_own_error_is_zero():
    v = verdict(cloud([0.0, 1e-9, 2e-9, 3e-9]), cloud([3e-6 + k * 1e-9 for k in range(4)]), 0, 0)
    # 3 um apart with zero own errors and nanometre spreads: ratios stay under 1/floor
    assert v.verdict == "agree"
    assert v.per_engine[0].gap_over_own_error == pytest.approx(3e-6 / FLOOR_RELATIVE, rel=1e-3)
    far = verdict(cloud([0.0, 0.0]), cloud([0.02, 0.02]), 0, 0)
    assert far.per_engine[0].gap_over_spread == pytest.approx(0.02 / FLOOR_RELATIVE)


def test_judged_at_the_largest_gap_when_the_end_agrees():
    a = cloud([0.0, 1e-6])
    b = cloud([0.0, 1e-6])
    b[:, 1, 0] += 0.5  # 0.5 m apart at t = 0.5 s only
    v = verdict(a, b)
    assert v.judged_at == "largest gap" and v.judged_time == 0.5
    assert v.max_gap == (pytest.approx(0.5), 0.5)
    # the instant is beyond every yardstick; two runs each cannot pass the test (p = 1/3)
    assert [s.verdict for s in v.timeline()] == ["agree", "differ", "agree"]
    assert v.timeline()[1] == Segment("differ", start=0.5, end=0.5, instants=1)
    assert v.verdict == "unresolved" and v.reason == "not separated"
    assert verdict_lines(summary_of(v, 2))[0].startswith(
        "**Unresolved**: the engines' runs are, at t = 0.500 s, a median"
    )


def test_energy_test_statistic():
    # two points each at 0 and 1 on a line: E|A-B| = 1, E|A-A'| = E|B-B'| = 0
    d = np.array([[0, 0, 1, 1], [0, 0, 1, 1], [1, 1, 0, 0], [1, 1, 0, 0]], dtype=float)
    t = energy_test(d, 2)
    assert t.statistic == pytest.approx(2.0) and t.exact and t.resamples == 6
    assert t.p_value == pytest.approx(2 / 6)


def test_verdict_dict_is_json_ready():
    import json

    v = verdict(cloud(np.arange(4) * 1e-6), cloud(1.0 + np.arange(4) * 1e-6))
    d = json.loads(json.dumps(verdict_dict(v)))
    assert d["verdict"] == "differ" and d["test"]["p_value"] == pytest.approx(2 / 70)
    within = {"A": {"spread": 0, "own_error": 0}, "B": {"spread": 0, "own_error": 0}}
    assert d["instants"] == {
        "total": 3,
        "agree": 0,
        "chaotic": 0,
        "unresolved": 0,
        "differ": 3,
        "within": within,  # every instant beyond both spreads and own errors
    }
    assert set(d["engine_figures"]) == {"A", "B"}


def test_a_p_value_from_random_splits_is_given_as_a_bound():
    a = cloud(np.arange(8) * 1e-6)
    b = cloud(1.0 + np.arange(8) * 1e-6)
    v = verdict(a, b)  # 12870 splits: 9999 random ones; only the true one and its mirror
    assert not v.test.exact and v.test.resamples == 9999  # are as far apart
    assert v.test.p_value < 0.001
    assert "(p < 0.001)" in verdict_lines(summary_of(v, 8))[1]
