"""The training engine's actions replayed open loop (src/simbridge/envs/sim2sim_openloop.py) and
a policy trained outside simbridge (sim2sim_external.py, trained_on.py), through
``simbridge sim2sim``.

- The same engine twice: the replay on the second copy stays within the training engine's
  chaos floor (``agree`` or ``chaotic``, never leaving its envelope), and the training engine's
  unperturbed replay repeats its closed-loop episode exactly.
- The Husky on PyBullet against PyBullet with the wheels' friction at 0.02 (the case of
  test_sim2sim.py): the replayed wheel speeds drive the base elsewhere, and the replay parts.
- ``--trained-on external:NAME``: no training engine, every pair tested, the stated contract as
  the contract table's first column; a misspelt engine still errors naming the engines.
"""

from __future__ import annotations

import dataclasses
import json

import pytest

from simbridge.cli.main import main
from simbridge.envs.errors import TaskFileError, UnknownTrainingEngineError
from simbridge.envs.reader import load_task, loads_task, shipped_tasks
from simbridge.envs.sim2sim import sim2sim
from simbridge.envs.sim2sim_report import headline, markdown, summary
from simbridge.envs.task import TrainedSpec
from simbridge.exceptions import InvalidArgumentError


def test_the_same_engine_replayed_stays_within_its_chaos_floor(tmp_path, capsys):
    out = tmp_path / "r"
    code = main(
        [
            "sim2sim",
            "reference",
            "--task",
            "cartpole",
            "--trained-on",
            "mujoco",
            "--backends",
            "mujoco",
            "mujoco",
            "--episodes",
            "2",
            "--openloop",
            "2",
            "--openloop-ensemble",
            "4",
            "--out",
            str(out),
        ]
    )
    assert code == 0, capsys.readouterr().err
    ol = json.loads((out / "summary.json").read_text())["openloop"]
    assert ol["trained_on"] == "mujoco"
    assert ol["seeds"] == [0, 1]
    assert ol["reproduces"] == {"0": 0.0, "1": 0.0}  # the replay repeats the closed loop
    assert [(r["engine"], r["seed"]) for r in ol["replays"]] == [("mujoco#2", 0), ("mujoco#2", 1)]
    for r in ol["replays"]:
        assert r["steps"] == 500  # the reference controller balances every seed
        assert r["verdict"] in ("agree", "chaotic"), r["quantities"]
        assert r["parts_at"] == {"joint_position_rms": None}
        v = r["quantities"]["joint_position_rms"]
        assert v["labels"] == ["mujoco", "mujoco#2"]
        assert v["engine_figures"]["mujoco"]["size"] == 4
    md = (out / "report.md").read_text()
    assert "## Where the physics parts" in md
    assert "never leaves mujoco's envelope" in md


def test_the_replay_parts_where_the_wheels_lose_their_friction():
    low = "pybullet+read_urdf_contact=False+lateral_friction=0.02"
    result = sim2sim(
        "reference",
        "husky_goto",
        trained_on="pybullet",
        backends=[low],
        episodes=1,
        openloop=1,
        openloop_ensemble=4,
    )
    ol = result.openloop
    (r,) = ol.replays
    assert r.engine == low
    assert set(r.verdicts) == {"joint_position_rms", "base_distance", "orientation"}
    assert r.verdicts["base_distance"].verdict == "differ"
    assert r.verdict == "differ"
    parts = r.parts_at["base_distance"]
    assert parts is not None and 0 < parts < r.steps * result.runs[0].contract["control_dt"]
    assert f"{low}: open loop, 1 seed(s): differ 1; parts first at" in markdown(result)


def test_a_policy_trained_outside_is_judged_against_its_stated_contract(tmp_path):
    task = load_task("cartpole")
    stated = TrainedSpec(framework="isaaclab", damping=(0.5,), armature=(0.01,))
    task = dataclasses.replace(task, trained=stated)
    result = sim2sim(
        "reference",
        task,
        trained_on="external:isaaclab",
        backends=["pybullet", "mujoco", "mujoco"],
        episodes=2,
        openloop=1,  # no training engine's log: the first engine's actions stand in
        openloop_ensemble=2,
    )
    ol = result.openloop
    assert ol is not None and (ol.trained_on, ol.outside, ol.seeds) == ("pybullet", "isaaclab", [0])
    assert [r.engine for r in ol.replays] == ["mujoco", "mujoco#2"]
    assert [r.engine.label for r in result.runs] == ["pybullet", "mujoco", "mujoco#2"]
    md = markdown(result)
    assert "Trained outside simbridge (**isaaclab**)" in md
    assert "| | stated (isaaclab) | pybullet | mujoco | mujoco#2 | departs |" in md
    assert "training engine |" not in md  # no engine is the training engine
    rows = {line.split(" | ")[0]: line for line in md.splitlines() if line.startswith("| ")}
    assert rows["| joint damping"].endswith("| yes |")  # stated 0.5, the URDF's 0
    assert rows["| joint damping"].startswith("| joint damping | 0.5 |")
    assert rows["| engine joint index"].startswith("| engine joint index | not stated |")
    assert rows["| armature (not read from an engine)"].startswith(
        "| armature (not read from an engine) | 0.01 | - |"
    )
    assert "## Every pair of engines" in md
    s = summary(result)
    pairs = [(p["first"], p["second"]) for p in s["external"]["pairs"]]
    assert pairs == [("pybullet", "mujoco"), ("pybullet", "mujoco#2"), ("mujoco", "mujoco#2")]
    assert s["external"]["stated"]["joint damping"] == "0.5"
    for e in s["engines"]:  # nothing against a training engine
        assert (e["p_value"], e["verdict"], e["discordant"]) == (None, None, None)
    assert s["openloop"]["outside"] == "isaaclab"
    assert "## Where the physics parts: the first engine's actions replayed open loop" in md
    assert result.points_at_contract is False


def test_an_outside_policy_failing_everywhere_points_at_its_stated_contract(tmp_path, monkeypatch):
    (tmp_path / "push_policy.py").write_text("def push(obs):\n    return [1.0]\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    result = sim2sim(
        "push_policy:push",
        "cartpole",
        trained_on="external:gymnasium",
        backends=["pybullet", "mujoco"],
        episodes=2,
    )
    assert [f.rate.successes for f in result.figures] == [0, 0]
    assert result.points_at_contract
    lines = headline(result)
    assert lines[-1].startswith("the policy succeeds on less than 50% of the seeds on every engine")
    assert "contract stated for gymnasium" in lines[-1]
    table = [line for line in markdown(result).splitlines() if line.startswith("| pybullet | 0/2")]
    assert table and table[0].split(" | ")[2:5] == [
        "-",
        "-",
        "-",
    ]  # nothing against a training engine


def test_a_task_file_states_its_training_run():
    body = shipped_tasks()["cartpole"].read_text(encoding="utf-8")
    task = loads_task(body + '\n[trained]\nframework = "isaaclab"\neffort_limit = 20.0\n')
    assert task.trained == TrainedSpec(framework="isaaclab", effort_limit=(20.0,))
    bad = body + "\n[trained]\narmatur = 0.01\n"
    with pytest.raises(TaskFileError, match=r"<task>:\d+: key 'trained.armatur'.*armature"):
        loads_task(bad)


def test_a_misspelt_training_engine_names_the_engines_and_the_external_form():
    with pytest.raises(UnknownTrainingEngineError, match="did you mean 'pybullet'") as err:
        sim2sim("reference", "cartpole", trained_on="pybulet", backends=[], episodes=1)
    assert "available backends: [" in str(err.value) and "'mujoco'" in str(err.value)
    assert "external:NAME" in str(err.value)
    with pytest.raises(InvalidArgumentError, match="expected external:NAME"):
        sim2sim("reference", "cartpole", trained_on="external:", backends=["pybullet"])


def test_explain_needs_a_training_engine(tmp_path, capsys):
    args = ["sim2sim", "reference", "--task", "cartpole", "--trained-on", "external:isaaclab"]
    code = main([*args, "--explain", "--episodes", "1", "--out", str(tmp_path)])
    assert code == 1
    assert "no training engine to move settings toward" in capsys.readouterr().err
