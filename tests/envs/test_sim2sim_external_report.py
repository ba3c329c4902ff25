"""report.html, the replayed seed and ``--fail-on-drop`` for a policy trained outside simbridge
(``--trained-on external:NAME``: no engine is the training engine), and the open-loop replays'
section folded in report.html (src/simbridge/envs/sim2sim_html.py, sim2sim_replay.py,
sim2sim_external.py, sim2sim.py, cli/sim2sim.py).

The parting case is made on purpose, as in test_sim2sim_html.py: a cart-pole policy that is the
reference LQR on PyBullet and pushes the cart with all its force elsewhere, so that every seed
succeeds on PyBullet and fails on MuJoCo.
"""

from __future__ import annotations

import json
import re
import textwrap

import pytest

from simbridge.cli.main import main
from simbridge.envs.evaluate import wilson
from simbridge.envs.paired import Engine, Record
from simbridge.envs.sim2sim import EngineRun, Sim2SimResult, figures
from simbridge.envs.sim2sim_external import dropped
from simbridge.envs.sim2sim_replay import choose_seed


@pytest.fixture
def policies(tmp_path, monkeypatch):
    """A module ``s2s_ext_policies`` on sys.path: the LQR on PyBullet, the full force elsewhere."""
    (tmp_path / "s2s_ext_policies.py").write_text(
        textwrap.dedent(
            """
            import numpy as np

            from simbridge.envs.controllers import CartPoleLQR

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
    return "s2s_ext_policies"


def _result(successes: list[list[bool]], labels: list[str], trained_on: str) -> Sim2SimResult:
    contract = {"control_dt": 0.1, "episode_steps": 10}
    runs = [
        EngineRun(
            Engine(label, label, "default"),
            [
                Record(i, ok, 10.0 if ok else 4.0, 10 if ok else 4, None if ok else "fell", 0, 0)
                for i, ok in enumerate(row)
            ],
            contract,
            0.0,
        )
        for label, row in zip(labels, successes, strict=True)
    ]
    seeds = list(range(len(successes[0])))
    return Sim2SimResult("cartpole", "p", trained_on, seeds, runs, figures(runs))


def test_outside_the_replayed_seed_is_the_first_where_any_two_engines_part():
    # seed 0: all fail; seed 1: the first engine fails, the others succeed (a training engine
    # that failed would have skipped it); seed 2: b alone fails
    rows = [[False, False, True], [False, True, False], [False, True, True]]
    ext = _result(rows, ["a", "b", "c"], "external:isaaclab")
    seed, why = choose_seed(ext)
    assert seed == 1 and "succeeds on b, c and fails on a" in why
    assert choose_seed(_result(rows, ["a", "b", "c"], "a"))[0] == 2  # a the training engine
    agree = _result([[True, False], [True, False]], ["a", "b"], "external:isaaclab")
    assert choose_seed(agree) == (
        0,
        "seed 0, the first seed: the engines agree on every seed's success",
    )


def test_outside_a_drop_is_any_pair_apart_in_either_order():
    # 6 seeds that succeed on b only: b rises against a, so a is below b
    rows = [[False] * 6, [True] * 6, [False] * 6]
    ext = _result(rows, ["a", "b", "c"], "external:isaaclab")
    assert dropped(ext) == ["a below b", "c below b"]
    # the same figures with a as the training engine: nothing dropped against a
    assert dropped(_result(rows, ["a", "b", "c"], "a")) == []
    assert dropped(_result([[True] * 6] * 2, ["a", "b"], "external:isaaclab")) == []


def _headline(page: str) -> tuple[list[tuple[str, str]], list[tuple[str, str]]]:
    """report.html's engine lines and pair lines, each ``(data-verdict, text)``."""

    def items(ul_id: str) -> list[tuple[str, str]]:
        m = re.search(rf'<ul id="{ul_id}">(.*?)</ul>', page, re.S)
        assert m, ul_id
        return [
            (v, re.sub(r"<[^>]+>", "", body))
            for v, body in re.findall(r'<li data-verdict="(\w+)">(.*?)</li>', m.group(1), re.S)
        ]

    return items("headline"), items("pairs")


def test_outside_report_html_fail_on_drop_and_replay(policies, tmp_path, capsys):
    out = tmp_path / "out"
    args = ["sim2sim", f"{policies}:LqrOnPybulletOnly", "--task", "cartpole"]
    args += ["--trained-on", "external:isaaclab", "--backends", "mujoco", "pybullet"]
    code = main([*args, "--episodes", "6", "--out", str(out), "--fail-on-drop", "--openloop", "0"])
    err = capsys.readouterr().err
    assert code == 3, err
    assert "between engines: mujoco below pybullet" in err

    page = (out / "report.html").read_text(encoding="utf-8")
    engines, pair = _headline(page)
    assert [v for v, _ in engines] == ["stated", "stated"]  # no training engine
    assert engines[0][1].startswith("mujoco: success 0/6")
    rate = wilson(6, 6)
    assert engines[1][1].startswith(f"pybullet: success 6/6 ({rate.low:.2f}-{rate.high:.2f}")
    assert "training engine" not in engines[0][1] + engines[1][1]
    assert len(pair) == 1 and pair[0][0] == "rise"
    assert pair[0][1].startswith("pybullet rise against mujoco")
    assert f"McNemar p = {2 * 0.5**6:.3g}" in pair[0][1]
    assert "succeeds on pybullet and fails on mujoco" in page  # the replayed seed's why
    doc = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert doc["replay"]["seed"] == 0


def test_outside_the_same_engine_twice_passes_fail_on_drop(policies, tmp_path, capsys):
    """...and its open-loop replay takes the first engine's actions (no log of the training
    run outside simbridge exists), saying so; the same engine twice agrees with itself."""
    args = ["sim2sim", f"{policies}:LqrOnPybulletOnly", "--task", "cartpole", "--no-replay"]
    args += ["--trained-on", "external:gymnasium", "--backends", "pybullet", "pybullet"]
    args += ["--openloop", "1", "--openloop-ensemble", "4"]
    code = main([*args, "--episodes", "3", "--out", str(tmp_path / "o"), "--fail-on-drop"])
    assert code == 0, capsys.readouterr().err
    page = (tmp_path / "o" / "report.html").read_text(encoding="utf-8")
    engines, pair = _headline(page)
    assert [v for v, _ in pair] == ["same"] and len(engines) == 2
    md = (tmp_path / "o" / "report.md").read_text(encoding="utf-8")
    assert "## Where the physics parts: the first engine's actions replayed open loop" in md
    assert "trained outside simbridge (gymnasium)" in md
    doc = json.loads((tmp_path / "o" / "summary.json").read_text(encoding="utf-8"))
    ol = doc["openloop"]
    assert ol["outside"] == "gymnasium" and ol["trained_on"] == "pybullet"
    assert ol["seeds"] == [0] and ol["reproduces"]["0"] == 0.0  # its own log, repeated exactly
    verdicts = [r["verdict"] for r in ol["replays"]]
    assert verdicts and all(v in ("agree", "chaotic") for v in verdicts), verdicts


def test_the_open_loop_replays_are_a_folded_section_of_report_html(tmp_path, capsys):
    out = tmp_path / "ol"
    args = ["sim2sim", "reference", "--task", "cartpole", "--no-replay", "--episodes", "1"]
    args += ["--trained-on", "pybullet", "--backends", "mujoco", "--openloop", "1"]
    assert main([*args, "--openloop-ensemble", "2", "--out", str(out)]) == 0
    page = (out / "report.html").read_text(encoding="utf-8")
    m = re.search(
        r'<details class="section"([^>]*)>\s*<summary><h2[^>]*>([^<]*open loop[^<]*)</h2>', page
    )
    assert m, "no open-loop section"
    assert " open" not in m.group(1)  # folded
    assert "actions replayed open loop" in m.group(2)
