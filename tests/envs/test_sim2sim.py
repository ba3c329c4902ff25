"""``simbridge sim2sim``'s two known answers and its bad input (src/simbridge/envs/sim2sim.py,
policies.py, sim2sim_report.py, cli/sim2sim.py).

- The same engine twice, through the same harness, shows no difference: every seed's episode is
  the same, so McNemar's test has no discordant pair (p = 1).
- The Husky's reference controller on PyBullet against PyBullet with the wheels' lateral
  friction at 0.02 drops significantly, and ``--explain`` ranks the friction, moved back to the
  training engine's, first. husky.urdf and plane.urdf state their friction in <contact>, which
  the profile's ``lateral_friction`` does not override (it is the friction of a link without
  one): the changed engine runs without the files' <contact> (``read_urdf_contact=False``) and
  with ``lateral_friction=0.02``. Either move back (``lateral_friction = 0.5``, or
  ``read_urdf_contact = True``) recovers every seed: the two share rank 1, the friction listed
  first.
- A policy of the wrong output size, a NaN action, an ONNX file that does not load, an unknown
  task, an unknown engine: each a specific error or a counted failure.
"""

from __future__ import annotations

import json
import textwrap

import numpy as np
import pytest

from simbridge.cli.main import main
from simbridge.envs.errors import PolicyError
from simbridge.envs.sim2sim import mcnemar, sim2sim
from simbridge.envs.sim2sim_explain import explain_drops
from simbridge.envs.sim2sim_report import contract_rows, markdown, summary


@pytest.fixture
def policies(tmp_path, monkeypatch):
    """A module ``bad_policies`` on sys.path: a policy of the wrong size and one that NaNs."""
    (tmp_path / "bad_policies.py").write_text(
        textwrap.dedent(
            """
            import numpy as np

            def three(obs):
                return np.zeros(3)

            class NanAfter:
                def __init__(self, env):
                    self.n = len(env.task.action.joints)
                    self.calls = 0

                def __call__(self, obs):
                    self.calls += 1
                    a = np.zeros(self.n)
                    if self.calls % 5 == 0:
                        a[0] = np.nan
                    return a
            """
        )
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    return "bad_policies"


def test_mcnemar_counts_the_discordant_pairs():
    # 7 seeds lost, 0 won: 2 * 0.5**7 = 0.0156
    b, c, p = mcnemar([True] * 10, [False] * 7 + [True] * 3)
    assert (b, c) == (7, 0)
    assert p == pytest.approx(2 * 0.5**7)
    assert mcnemar([True, False], [True, False])[2] == 1.0


def test_the_training_engine_runs_first_and_a_repeat_is_labelled():
    from simbridge.envs.paired import parse_engines

    engines = parse_engines(
        ["pybullet", "mujoco", "mujoco", "physx+lateral_friction=0.9"],
        "mujoco",
        "pybullet",
        ["pybullet", "mujoco", "physx"],
    )
    assert [(e.label, e.backend, e.profile) for e in engines] == [
        ("mujoco", "mujoco", "pybullet"),
        ("pybullet", "pybullet", "pybullet"),
        ("mujoco#2", "mujoco", "pybullet"),
        ("physx+lateral_friction=0.9", "physx", "pybullet+lateral_friction=0.9"),
    ]


def test_the_same_engine_twice_shows_no_difference(tmp_path):
    result = sim2sim(
        "reference", "husky_goto", trained_on="pybullet", backends=["pybullet"], episodes=6
    )
    assert [r.engine.label for r in result.runs] == ["pybullet"]
    twice = sim2sim(
        "simbridge.envs.controllers:DriveToGoal",
        "husky_goto",
        trained_on="pybullet",
        backends=["pybullet", "pybullet"],
        episodes=6,
    )
    a, b = twice.figures
    assert [r.engine.label for r in twice.runs] == ["pybullet", "pybullet#2"]
    assert a.rate.successes == 6 and b.rate.successes == 6
    assert b.discordant == (0, 0) and b.p_value == 1.0 and b.verdict == "same"
    assert [r.steps for r in twice.runs[0].records] == [r.steps for r in twice.runs[1].records]
    assert b.ret_difference.value == 0.0
    text = markdown(twice)
    assert "| pybullet#2 | 6/6 (0.61-1.00) | 0, 0 | 1 | same |" in text
    assert "## The contract, engine beside engine" in text
    assert "| joint order (action) | front_left_wheel" in text


def test_low_friction_drops_and_explain_puts_the_friction_first():
    result = sim2sim(
        "reference",
        "husky_goto",
        trained_on="pybullet",
        backends=["pybullet+read_urdf_contact=False+lateral_friction=0.02"],
        episodes=8,
    )
    explain_drops("husky_goto", result)
    train, low = result.figures
    assert train.rate.successes == 8
    assert low.verdict == "drop" and low.p_value < 0.05, (low.rate, low.p_value)
    (entry,) = result.explain
    ranked = [(c["rank"], c["name"], c["successes"]) for c in entry["candidates"]]
    assert ranked == [(1, "lateral_friction", 8), (1, "read_urdf_contact", 8)]
    assert entry["candidates"][0]["recovered"] == 1.0
    assert entry["candidates"][0]["setting"] == "lateral_friction = 0.5"
    doc = summary(result)
    json.dumps(doc)
    assert doc["engines"][1]["verdict"] == "drop"
    rows = dict(contract_rows(result))
    assert rows["profile"] == ["pybullet", "pybullet+read_urdf_contact=False+lateral_friction=0.02"]
    assert "| 1= | lateral_friction = 0.5 | 8/8 (0.68-1.00) | 0.00781 | 100% |" in markdown(result)


def test_a_policy_of_the_wrong_size_names_both_sizes_and_the_joints(policies):
    with pytest.raises(
        PolicyError,
        match=r"returned 3 action entries; the task 'husky_goto' "
        r"takes 4, one velocity entry per joint in this order: \['front_left_wheel'",
    ):
        sim2sim(f"{policies}:three", "husky_goto", trained_on="pybullet", backends=[], episodes=1)


def test_a_nan_action_is_that_episode_s_failure_and_said(policies, tmp_path, capsys):
    code = main(
        [
            "sim2sim",
            f"{policies}:NanAfter",
            "--task",
            "cartpole",
            "--trained-on",
            "mujoco",
            "--backends",
            "mujoco",
            "--episodes",
            "2",
            "--out",
            str(tmp_path / "out"),
        ]
    )
    assert code == 0
    out = capsys.readouterr().out
    assert "mujoco: success 0/2" in out and "2 NaN action(s)" in out
    report = (tmp_path / "out" / "report.md").read_text()
    assert "nan_action 2" in report and "never passed to the engine" in report
    doc = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert [e["failure"] for e in doc["engines"][0]["episodes"]] == ["nan_action"] * 2
    assert [e["steps"] for e in doc["engines"][0]["episodes"]] == [4, 4]
    assert doc["points_at_contract"] is True


def test_an_onnx_file_that_does_not_load(tmp_path, capsys):
    bad = tmp_path / "policy.onnx"
    bad.write_bytes(b"not a model")
    code = main(
        [
            "sim2sim",
            str(bad),
            "--task",
            "cartpole",
            "--trained-on",
            "pybullet",
            "--backends",
            "pybullet",
            "--episodes",
            "1",
            "--out",
            str(tmp_path / "o"),
        ]
    )
    err = capsys.readouterr().err
    assert code == 1
    try:
        import onnxruntime  # noqa: F401
    except ImportError:
        assert "needs a runtime that is not installed: pip install onnxruntime" in err
    else:
        assert "the ONNX file does not load" in err


def test_an_onnx_policy_runs(tmp_path):
    onnx = pytest.importorskip("onnx")
    pytest.importorskip("onnxruntime")
    from onnx import TensorProto, helper

    # a linear policy: action = obs @ W, W (4, 1) the LQR's sign on the pole angle only
    w = np.zeros((4, 1), np.float32)
    graph = helper.make_graph(
        [helper.make_node("MatMul", ["obs", "W"], ["action"])],
        "linear",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, [1, 4])],
        [helper.make_tensor_value_info("action", TensorProto.FLOAT, [1, 1])],
        [helper.make_tensor("W", TensorProto.FLOAT, [4, 1], w.ravel().tolist())],
    )
    path = tmp_path / "zero.onnx"
    onnx.save(helper.make_model(graph), str(path))
    result = sim2sim(str(path), "cartpole", trained_on="pybullet", backends=[], episodes=2)
    # action 0 fails every cart-pole seed (tests/envs/test_reference.py)
    assert result.figures[0].rate.successes == 0
    assert result.points_at_contract


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["--task", "cartpol", "--trained-on", "pybullet"],
            "shipped: \\['a1_stand', 'a1_walk', 'ant', 'cartpole'",
        ),
        (["--task", "cartpole", "--trained-on", "bullet"], "unknown backend 'bullet'"),
        (
            ["--task", "cartpole", "--trained-on", "pybullet", "--backends", "pybullet+frction=1"],
            "unknown entry 'frction'",
        ),
    ],
)
def test_unknown_task_and_engine(args, message, tmp_path, capsys):
    code = main(["sim2sim", "reference", *args, "--episodes", "1", "--out", str(tmp_path)])
    assert code == 1
    err = capsys.readouterr().err
    assert err.startswith("simbridge: error: ")
    assert __import__("re").search(message, err), err


@pytest.mark.parametrize(
    ("policy", "message"),
    [
        ("no_such_module_here:act", "module 'no_such_module_here' does not import"),
        (
            "simbridge.envs.controllers:Nope",
            "has no attribute 'Nope'; public names there: .*'DriveToGoal'",
        ),
        ("simbridge.envs.controllers:CONTROLLERS", "'CONTROLLERS' is a dict, not a callable"),
        ("policy.bin", "expected 'reference', module:callable, or a file ending in .jit, .onnx"),
        ("missing.onnx", "'missing.onnx': no such file"),
    ],
)
def test_a_policy_that_does_not_load_says_why(policy, message):
    with pytest.raises(PolicyError, match=message):
        sim2sim(policy, "cartpole", trained_on="pybullet", backends=[], episodes=1)
