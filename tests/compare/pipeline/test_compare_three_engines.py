"""Three engines in one comparison, every pair judged, before a third engine exists: MuJoCo's
backend registered a second time under another name (``mujoco-b``) runs beside PyBullet and
MuJoCo, under another profile or the same one.

Registration goes through :func:`simbridge.registry.register` on a copy of the registry that the
test restores, so no other test sees the extra name. Ensembles run in this process
(``workers=0``, or ``--ensemble 1`` from the command line): a worker process would not have the
name registered.
"""

from __future__ import annotations

import json

import pytest

from simbridge import registry
from simbridge.cli import main
from simbridge.compare import compare, diff, report, summary

SECOND = "mujoco-b"


@pytest.fixture
def third_engine(monkeypatch: pytest.MonkeyPatch) -> str:
    for name in ("pybullet", "mujoco"):  # shipped: never skipped
        assert registry.unavailable_reason(name) is None, name
    monkeypatch.setattr(registry, "_REGISTRY", dict(registry._REGISTRY))
    monkeypatch.setattr(registry, "_LOADED", dict(registry._LOADED))
    registry.register(SECOND, "simbridge.backends.mujoco:MujocoBackend", requires=("mujoco",))
    return SECOND


@pytest.fixture
def three(third_engine):
    return compare(
        "pendulum",
        ["pybullet", "mujoco", third_engine],
        profile=["pybullet", "pybullet", "urdf"],
        duration=0.5,
        ensemble=2,
        workers=0,
    )


def test_every_pair_of_three_engines_is_judged(three):
    c = three
    assert c.labels == ("pybullet (pybullet)", "mujoco (pybullet)", "mujoco-b (urdf)")
    assert [(p.a, p.b) for p in c.pairs] == [(0, 1), (0, 2), (1, 2)]
    assert len(c.ensembles) == 3 and {k for k, _ in c.own} == {0, 1, 2}
    q, dt = c.headline_quantity, c.timestep
    for p in c.pairs:
        assert p.verdict is not None
        assert p.verdict.labels == (c.labels[p.a], c.labels[p.b])
        assert p.cross[dt].final[q] == diff(c.runs[(p.a, dt)], c.runs[(p.b, dt)]).final[q]
    # the first pair is the headline's
    assert c.verdict is c.pairs[0].verdict and c.cross is c.pairs[0].cross
    # MuJoCo under the urdf profile parts from MuJoCo under PyBullet's by far more than
    # PyBullet and MuJoCo part under one profile (4.4 mm against 1e-10 m, measured)
    gaps = [p.cross[dt].final[q] for p in c.pairs]
    assert gaps[1] > 1e3 * gaps[0] and gaps[2] > 1e3 * gaps[0]


def test_summary_has_a_section_per_pair_and_the_first_pair_on_top(three):
    s = summary(three)
    assert s["labels"] == list(three.labels) and len(s["backends"]) == 3
    assert [p["labels"] for p in s["pairs"]] == [
        ["pybullet (pybullet)", "mujoco (pybullet)"],
        ["pybullet (pybullet)", "mujoco-b (urdf)"],
        ["mujoco (pybullet)", "mujoco-b (urdf)"],
    ]
    first = s["pairs"][0]
    for key in ("headline", "cross", "verdict", "parting", "parts"):
        assert s[key] == first[key], key
    for per_engine in (s["own"], s["ensemble"]["engines"], s["events"], s["departures"]):
        assert list(per_engine) == s["labels"]
    assert list(s["manifest"]["engines"]) == s["labels"]
    assert s["manifest"]["engines"]["mujoco-b (urdf)"]["backend"] == "mujoco"
    for p in s["pairs"]:
        assert list(p["headline"]["own_error"]) == p["labels"]
        assert p["verdict"]["labels"] == p["labels"]


def test_the_same_engine_under_two_names_agrees_exactly(third_engine):
    """A backend under a second name, same profile: its runs are the same runs."""
    c = compare("pendulum", ["mujoco", third_engine], duration=0.5, ensemble=2, workers=0)
    assert c.labels == ("mujoco", "mujoco-b")
    assert c.verdict is not None and c.verdict.verdict == "agree"
    assert all(v == 0.0 for v in c.cross[c.timestep].maximum.values())


def test_the_report_of_three_engines_has_a_row_per_pair(three, tmp_path):
    text = report(three, tmp_path, plots=False, trajectories=False).read_text("utf-8")
    assert text.startswith(
        "# pendulum: pybullet (pybullet), mujoco (pybullet) and mujoco-b (urdf)\n"
    )
    head, table = text.split("## Every pair of engines", 1)
    assert "\n\n- pybullet (pybullet) and mujoco (pybullet): " in head
    rows = [line for line in table.split("\n\n")[2].splitlines() if line.startswith("| ")]
    assert rows[0].startswith("| pair | verdict | judged gap [95%] (when) | nominal gap (end) |")
    s = json.loads((tmp_path / "summary.json").read_text("utf-8"))
    body = [r.strip("| ").split(" | ") for r in rows[1:]]
    assert [r[0] for r in body] == [" and ".join(p["labels"]) for p in s["pairs"]]
    for cells, p in zip(body, s["pairs"], strict=True):
        assert cells[1].startswith(p["verdict"]["verdict"]), cells


def test_the_command_line_takes_three_backends(third_engine, tmp_path, capsys):
    out = tmp_path / "three"
    argv = ["compare", "pendulum", "--backends", "pybullet", "mujoco", third_engine]
    argv += ["--profile", "pybullet", "pybullet", "urdf", "--duration", "0.25"]
    argv += ["--ensemble", "1", "--no-plots", "--out", str(out)]
    assert main(argv) == 0
    printed = capsys.readouterr().out.splitlines()  # the short headline: a line per pair
    assert len(printed) <= 6 and printed[0].startswith("pendulum on pybullet (pybullet), ")
    assert [x.split(":")[0] for x in printed[1:4]] == [
        "  pybullet (pybullet) and mujoco (pybullet)",
        "  pybullet (pybullet) and mujoco-b (urdf)",
        "  mujoco (pybullet) and mujoco-b (urdf)",
    ]
    assert "Every pair of the 3 engines" in (out / "report.md").read_text("utf-8")
    s = json.loads((out / "summary.json").read_text("utf-8"))
    assert len(s["pairs"]) == 3 and s["backends"] == ["pybullet", "mujoco", third_engine]


@pytest.mark.parametrize(
    "argv",
    [
        ["--backends", "pybullet"],
        ["--backends", "pybullet", "mujoco", "--profile", "urdf", "urdf", "urdf"],
        ["--backends", "pybullet", "mujoco", "mujoco", "--profile", "urdf", "urdf"],
    ],
)
def test_backends_take_two_or_more_and_profiles_one_or_one_each(argv, capsys):
    assert main(["compare", "pendulum", *argv]) == 2
    err = capsys.readouterr().err
    assert "--backends takes two or more" in err or "--profile takes one profile" in err
