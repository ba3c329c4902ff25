"""Engine settings in a study: a scenario's [engines.*] tables (read, checked, written back),
compare(engine_settings=) on top, carried to every run (ensemble members in their worker
processes included), and recorded in summary.json and report.md.

The scenario is robots/free_box.urdf dropped onto robots/plane.urdf: MuJoCo's contact margin
sets where the box comes to rest (the margin above the plane), a figure each run shows.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from simbridge.cli import main
from simbridge.compare import compare, dumps_scenario, loads_scenario, report
from simbridge.compare.errors import ScenarioError

BOX = """
name = "box-drop"
description = "a free box dropped 5 cm onto the plane"
timestep = "1/240"
subject = "box"
{engines}
[[robots]]
name = "plane"
urdf = "plane.urdf"
fixed_base = true

[[robots]]
name = "box"
urdf = "free_box.urdf"
position = [0.0, 0.0, 0.25]

[[phases]]
name = "drop"
steps = 96
"""

SETTINGS = """
[engines.mujoco]
margin = 0.02
solref = [0.01, 1.0]

[engines.pybullet]
contactERP = 0.2
"""


def test_engines_tables_are_read_checked_and_written_back():
    s = loads_scenario(BOX.format(engines=SETTINGS))
    assert s.engine("mujoco") == {"margin": 0.02, "solref": [0.01, 1.0]}
    assert s.engine("pybullet") == {"contactERP": 0.2}
    assert s.engine("physx") == {}
    text = dumps_scenario(s)
    assert "[engines.mujoco]" in text
    again = loads_scenario(text)
    assert again == s and dumps_scenario(again) == text
    assert loads_scenario(BOX.format(engines="")).engines == ()


@pytest.mark.parametrize(
    ("table", "words", "line"),
    [
        ("[engines.bullet]\nerp = 0.3\n", ["unknown backend 'bullet'", "pybullet", "mujoco"], 6),
        ("[engines.mujoco]\nstiffness = 3\n", ["mujoco.stiffness", "valid settings", "solref"], 7),
        ("[engines.mujoco]\nimpratio = 0\n", ["mujoco.impratio", "> 0"], 7),
        ("[engines.pybullet]\nuseSplitImpulse = 1\n", ["true or false"], 7),
    ],
)
def test_a_bad_engines_table_names_the_key_and_its_line(table, words, line):
    with pytest.raises(ScenarioError) as err:
        loads_scenario(BOX.format(engines=table), file="box.toml")
    msg = str(err.value)
    assert all(w in msg for w in words), msg
    assert err.value.line == line


def _rest(c, slot):
    """Where the box's base ends (m, z) in backend ``slot``'s nominal run."""
    tr = c.runs[(slot, c.timestep)]
    return float(tr.bodies["box"].base_position[-1][2])


def test_compare_carries_the_settings_to_every_run_and_records_them(tmp_path):
    sc = loads_scenario(BOX.format(engines=SETTINGS))
    c = compare(
        sc,
        ["mujoco", "pybullet"],
        ensemble=3,
        workers=1,
        resync_every=0,
        engine_settings={"mujoco": {"margin": 0.05}},  # on top of the scenario's 0.02
    )
    # MuJoCo's box rests the margin above the plane, 0.05 (the call's, not the file's)
    assert _rest(c, 0) == pytest.approx(0.25, abs=2e-3)
    assert _rest(c, 1) == pytest.approx(0.20, abs=2e-3)
    for slot in (0, 1):  # the half-step run too
        half = c.runs[(slot, c.timestep / 2)]
        assert float(half.bodies["box"].base_position[-1][2]) == pytest.approx(
            _rest(c, slot), abs=2e-3
        )
    # ensemble members, run in a worker process, rest where the nominal run does
    mujoco = next(e for e in c.ensembles if e.backend == "mujoco")
    assert len(mujoco.end_points) == 3
    np.testing.assert_allclose(mujoco.end_points[:, 2], 0.25, atol=3e-3)
    manifest = c.runs[(0, c.timestep)].manifest
    assert manifest["engine_settings"]["margin"] == 0.05
    assert manifest["engine_settings"]["solref"] == [0.01, 1.0]
    assert manifest["engine_settings"]["impratio"] == 1.0  # a default, in force
    out = tmp_path / "r"
    report(c, out, plots=False)
    summary = json.loads((out / "summary.json").read_text("utf-8"))
    assert summary["engine_settings"]["mujoco"]["margin"]["value"] == 0.05
    assert summary["engine_settings"]["mujoco"]["margin"]["default"] == 0.001
    assert summary["engine_settings"]["pybullet"] == {
        "contactERP": {
            "value": 0.2,
            "default": 0.08,
            "unit": "",
            "meaning": summary["engine_settings"]["pybullet"]["contactERP"]["meaning"],
        }
    }
    text = (out / "report.md").read_text("utf-8")
    assert "## Engine settings" in text and "| mujoco | `margin` | 0.05 m | 0.001 m |" in text


def test_no_settings_no_part(tmp_path):
    c = compare(
        loads_scenario(BOX.format(engines="")),
        ["mujoco", "pybullet"],
        ensemble=1,
        resync_every=0,
        duration=0.1,
    )
    assert _rest(c, 0) == pytest.approx(0.201, abs=2e-3)  # MuJoCo's 1 mm default margin
    out = tmp_path / "r"
    report(c, out, plots=False)
    summary = json.loads((out / "summary.json").read_text("utf-8"))
    assert "engine_settings" not in summary
    assert "Engine settings" not in (out / "report.md").read_text("utf-8")


def test_the_command_line_sets_and_lists_settings(tmp_path, capsys):
    path = tmp_path / "box.toml"
    path.write_text(BOX.format(engines=""), encoding="utf-8")
    argv = ["compare", str(path), "--backends", "mujoco", "pybullet", "--ensemble", "1"]
    argv += ["--resync-every", "0", "--no-plots", "--out", str(tmp_path / "r")]
    assert main([*argv, "--set", "mujoco.margin=0.03", "--set", "mujoco.cone=elliptic"]) == 0
    summary = json.loads((tmp_path / "r" / "summary.json").read_text("utf-8"))
    assert set(summary["engine_settings"]["mujoco"]) == {"margin", "cone"}
    capsys.readouterr()
    assert main([*argv, "--set", "mujoco.stiffness=3"]) == 2  # bad usage, before any run
    assert "mujoco.stiffness" in capsys.readouterr().err
    assert main(["settings", "mujoco"]) == 0
    listed = capsys.readouterr().out
    assert "[engines.mujoco]" in listed and "solref" in listed and "impratio" in listed
    assert main(["settings", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert {"pybullet", "mujoco", "physx"} <= set(data)
