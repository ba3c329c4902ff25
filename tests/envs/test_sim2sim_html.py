"""``simbridge sim2sim``'s report.html, survival curves, torque saturation and joint-limit hits,
and ``--fail-on-drop`` (src/simbridge/envs/sim2sim_html.py, survival.py, sim2sim_figures.py,
sim2sim_effort.py, sim2sim_replay.py, cli/sim2sim.py).

The parting case is made on purpose: a cart-pole policy that is the reference LQR on PyBullet
and pushes the cart with all its force on MuJoCo, so that every seed succeeds on the training
engine (PyBullet) and fails on the other. The replay must then show seed 0 on both engines.
"""

from __future__ import annotations

import base64
import dataclasses
import html
import json
import re
import textwrap
from html.parser import HTMLParser

import numpy as np
import pytest

from simbridge.cli.main import main
from simbridge.envs.evaluate import wilson
from simbridge.envs.paired import Engine, Record, run_engine
from simbridge.envs.sim2sim import EngineRun, Sim2SimResult, figures
from simbridge.envs.sim2sim_replay import choose_seed
from simbridge.envs.survival import kaplan_meier


@pytest.fixture
def policies(tmp_path, monkeypatch):
    """A module ``s2s_policies`` on sys.path: the full force, no force, and the LQR that pushes
    with all its force on any engine but PyBullet."""
    (tmp_path / "s2s_policies.py").write_text(
        textwrap.dedent(
            """
            import numpy as np

            from simbridge.envs.controllers import CartPoleLQR

            class Full:
                def __init__(self, env):
                    self.n = len(env.task.action.joints)

                def __call__(self, obs):
                    return np.ones(self.n)

            class Zero(Full):
                def __call__(self, obs):
                    return np.zeros(self.n)

            class LqrOnPybulletOnly:
                def __init__(self, env):
                    self.lqr = CartPoleLQR(env)
                    self.push = env.backend != "pybullet"

                def __call__(self, obs):
                    return np.ones(1) if self.push else self.lqr(obs)
            """
        )
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    return "s2s_policies"


def _record(steps: int, failure: str | None, seed: int = 0) -> Record:
    return Record(seed, failure is None, float(steps), steps, failure, 0.0, 0.0)


# ---------------------------------------------------------------- Kaplan-Meier


KNOWN = [
    _record(3, "fell"),
    _record(5, None),  # censored at 5: at risk at 5, never fails
    _record(5, "fell"),
    _record(8, "fell"),
    _record(8, "fell"),
    _record(10, None),
]


def test_kaplan_meier_matches_a_hand_computation():
    km = kaplan_meier(KNOWN)
    # failures at 3 (6 at risk, 1 fails), 5 (5 at risk: 5, 5, 8, 8, 10; 1 fails), 8 (3, 2)
    assert km.times.tolist() == [0, 3, 5, 8]
    assert km.at_risk.tolist() == [6, 6, 5, 3]
    assert km.failed.tolist() == [0, 1, 1, 2]
    s3, s5, s8 = 5 / 6, 5 / 6 * 4 / 5, 5 / 6 * 4 / 5 * 1 / 3
    np.testing.assert_allclose(km.survival, [1.0, s3, s5, s8], rtol=1e-12)
    assert [km.at(t) for t in (0, 2.9, 3, 4, 5, 7.5, 8, 10)] == pytest.approx(
        [1.0, 1.0, s3, s3, s5, s5, s8, s8]
    )
    # the log-log band at step 3: Greenwood's sum 1 / (6 * 5)
    half = 1.959964 * np.sqrt(1 / 30) / abs(np.log(s3))
    assert km.low[1] == pytest.approx(s3 ** np.exp(half))
    assert km.high[1] == pytest.approx(s3 ** np.exp(-half))
    assert np.all(km.low <= km.survival) and np.all(km.survival <= km.high)
    assert (km.low[0], km.high[0]) == (1.0, 1.0)


def test_every_failure_at_once_drops_the_curve_to_zero():
    km = kaplan_meier([_record(4, "fell"), _record(4, "fell")])
    assert km.survival.tolist() == [1.0, 0.0]
    assert (km.low[-1], km.high[-1]) == (0.0, 0.0)


def _fake_result(successes: list[list[bool]], labels: list[str]) -> Sim2SimResult:
    contract = {"control_dt": 0.1, "episode_steps": 10}
    runs = [
        EngineRun(
            Engine(label, label, "default"),
            [_record(10 if ok else 4, None if ok else "fell", i) for i, ok in enumerate(row)],
            contract,
            0.0,
        )
        for label, row in zip(labels, successes, strict=True)
    ]
    seeds = list(range(len(successes[0])))
    return Sim2SimResult("cartpole", "p", labels[0], seeds, runs, figures(runs))


def test_the_quarters_are_the_curve_s():
    run = EngineRun(
        Engine("e", "e", "default"), KNOWN, {"control_dt": 0.1, "episode_steps": 10}, 0.0
    )
    (f,) = figures([run])
    assert f.survival == pytest.approx([1.0, 5 / 6 * 4 / 5, 5 / 6 * 4 / 5, 5 / 6 * 4 / 5 / 3])


def test_the_replayed_seed_is_the_first_where_the_engines_part():
    result = _fake_result(
        [[False, True, True, True], [False, True, False, False], [True, True, True, False]],
        ["a", "b", "c"],
    )
    seed, why = choose_seed(result)
    assert seed == 2 and "fails on b" in why
    same = _fake_result([[True, False], [True, True]], ["a", "b"])
    assert choose_seed(same)[0] == 0
    assert "no seed succeeds on the training engine and fails on another" in choose_seed(same)[1]


# ---------------------------------------------------------------- saturation and joint limits


def test_full_force_saturates_and_reaches_the_rail_s_end(policies, backend):
    """The cart pushed with the task's full 10 N, no termination: every physics step is at the
    effort limit, and the cart reaches its rail's end (15 m) within 300 control steps (6.25 s);
    no force: neither."""
    from simbridge.envs.reader import load_task

    task = dataclasses.replace(load_task("cartpole"), terminations=(), episode_steps=300)
    engine = Engine(backend, backend, task.profile)
    (full,) = run_engine(task, engine, f"{policies}:Full", [0]).records
    (zero,) = run_engine(task, engine, f"{policies}:Zero", [0]).records
    for r in (full, zero):
        assert 0.0 <= r.saturated_share <= 1.0 and 0.0 <= r.limit_share <= 1.0
    assert full.saturated_share == 1.0
    assert 0.1 < full.limit_share < 1.0
    assert zero.saturated_share == 0.0 and zero.limit_share == 0.0


def test_wheels_asked_their_full_speed_saturate_their_motors_a_while(policies, backend):
    """The Husky's velocity motors read back from the engine: asked 8 rad/s from rest, each
    wheel's motor is at its 50 N m until the wheels are up to speed, then no longer; asked 0
    rad/s at rest, never."""
    from simbridge.envs.reader import load_task

    task = load_task("husky_goto")
    task = dataclasses.replace(task, terminations=(), success=(), episode_steps=120)
    engine = Engine(backend, backend, task.profile)
    (full,) = run_engine(task, engine, f"{policies}:Full", [0]).records
    (zero,) = run_engine(task, engine, f"{policies}:Zero", [0]).records
    assert 0.0 < full.saturated_share < 0.5
    assert zero.saturated_share == 0.0
    assert full.limit_share == zero.limit_share == 0.0  # continuous wheels: no limit


def test_the_probe_steps_the_same_physics(backend):
    """With the probe installed the velocity mode runs its 4 physics steps one at a time: the
    episode is the same as without it."""
    from simbridge.envs.env import SimEnv
    from simbridge.envs.sim2sim_effort import EffortProbe

    env = SimEnv("husky_goto", backend=backend)
    try:
        actions = np.random.default_rng(0).uniform(-1, 1, (30, 4))
        runs = []
        for probed in (False, True):
            probe = EffortProbe(env)
            if probed:
                probe.install()
            obs = [env.reset(seed=3)[0]]
            obs += [env.step(a)[0] for a in actions]
            probe.remove()
            runs.append(np.array(obs))
            if probed:
                assert probe.steps == 30 * 4
        np.testing.assert_array_equal(runs[0], runs[1])
    finally:
        env.close()


# ---------------------------------------------------------------- report.html and exit status


class _Order(HTMLParser):
    """The page's landmarks in document order, and the headline's lines."""

    def __init__(self) -> None:
        super().__init__()
        self.order: list[str] = []
        self.lines: list[tuple[str, str]] = []
        self._li: str | None = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if (tag, a.get("class")) == ("details", "section"):
            self.order.append("section")
        elif a.get("id") in ("headline", "replay"):
            self.order.append(a["id"])
        if tag == "li" and self.order[-1:] == ["headline"] and "data-verdict" in a:
            self._li = a["data-verdict"]
            self.lines.append((self._li, ""))

    def handle_data(self, data):
        if self._li is not None:
            v, text = self.lines[-1]
            self.lines[-1] = (v, text + data)

    def handle_endtag(self, tag):
        if tag == "li":
            self._li = None


def _scene_names(page: str) -> list[str]:
    """The names of the nodes in report.html's recorded scene."""
    import msgspec
    import zstandard

    srcdoc = re.search(r'<iframe id="replay"[^>]* srcdoc="([^"]*)"', page)
    assert srcdoc is not None, "no replay iframe"
    data = re.search(r'__VISER_EMBED_DATA__="([^"]+)"', html.unescape(srcdoc.group(1)))
    assert data is not None, "no recording in the viewer"
    raw = base64.b64decode(data.group(1))
    inner = zstandard.ZstdDecompressor().decompress(raw[8:], max_output_size=1 << 30)
    n = int.from_bytes(inner[:8], "little")
    rec = msgspec.msgpack.decode(inner[8 : 8 + n])
    return [m["name"] for _, m in rec["messages"] if "name" in m]


def test_report_html_opens_on_the_headline_then_the_replay(policies, tmp_path, capsys):
    pytest.importorskip("viser", reason="the replay needs viser (simbridge[report])")
    out = tmp_path / "out"
    args = ["sim2sim", f"{policies}:LqrOnPybulletOnly", "--task", "cartpole"]
    args += ["--trained-on", "pybullet", "--backends", "mujoco", "--episodes", "6"]
    code = main([*args, "--out", str(out), "--fail-on-drop"])
    err = capsys.readouterr().err
    assert code == 3, err
    assert "success dropped significantly on mujoco" in err

    page = (out / "report.html").read_text(encoding="utf-8")
    order = _Order()
    order.feed(page)
    assert order.order[:2] == ["headline", "replay"]
    assert order.order[2:] and set(order.order[2:]) == {"section"}
    rate = wilson(6, 6)
    (v0, line0), (v1, line1) = order.lines
    assert v0 == "training" and line0.startswith(
        f"pybullet: success 6/6 ({rate.low:.2f}-{rate.high:.2f}, 95% Wilson)"
    )
    assert v1 == "drop" and "mujoco: success 0/6" in line1
    assert f"McNemar p = {2 * 0.5**6:.3g}" in line1
    assert "seed 0, the first where the engines part" in page
    names = _scene_names(page)
    for engine in ("pybullet", "mujoco"):
        assert any(n.startswith(f"/{engine}/cartpole/") for n in names), engine
    assert re.search(r'<img[^>]+src="data:image/png;base64,', page)  # the survival figure

    png = out / "survival.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert "![Kaplan-Meier survival of every engine](survival.png)" in (
        out / "report.md"
    ).read_text(encoding="utf-8")
    doc = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    train, other = doc["engines"]
    assert train["survival_curve"]["survival"] == [1.0]  # no failure: the curve stays at 1
    assert other["survival_curve"]["survival"][-1] == 0.0
    assert other["saturated_share"] == 1.0  # the full push, every physics step
    assert 0.0 <= train["saturated_share"] < 1.0
    assert doc["replay"]["seed"] == 0
    assert doc["replay"]["matches_evaluation"] == {"pybullet": True, "mujoco": True}
    for f in doc["replay"]["trajectories"]:
        assert (out / f).is_file()


def test_without_fail_on_drop_a_drop_exits_0_and_no_drop_exits_0(policies, tmp_path, capsys):
    base = ["sim2sim", f"{policies}:LqrOnPybulletOnly", "--task", "cartpole", "--no-replay"]
    drop = [*base, "--trained-on", "pybullet", "--backends", "mujoco", "--episodes", "6"]
    assert main([*drop, "--out", str(tmp_path / "a")]) == 0
    assert not (tmp_path / "a" / "trajectories").exists()
    page = (tmp_path / "a" / "report.html").read_text(encoding="utf-8")
    assert 'id="headline"' in page and 'id="replay"' not in page
    same = [*base, "--trained-on", "pybullet", "--backends", "pybullet", "--episodes", "1"]
    assert main([*same, "--out", str(tmp_path / "b"), "--fail-on-drop"]) == 0
    bad = ["sim2sim", "reference", "--task", "cartpol", "--trained-on", "pybullet"]
    assert main([*bad, "--out", str(tmp_path / "c"), "--fail-on-drop"]) == 1  # an error stays 1
