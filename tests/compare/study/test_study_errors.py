"""What a new user gets wrong on a study, said before any engine runs (exit 2 at the command
line), and what a study says of a scenario it cannot judge by a rule:

- ``--set`` / ``engine_settings=`` / ``--vary BACKEND.KEY`` for an engine the study does not
  run (a flat sweep, silently, before): EngineNotInStudyError naming the setting's engine and
  the study's; a scenario's own ``[engines.physx]`` table with PhysX not run stays accepted;
- ``--vary KEY@N`` past the engines: usage and exit 2, as ``KEY@0``;
- did you mean: a scenario key (PyBullet's ``base_position`` too), a profile, a ``--vary``
  setting;
- explain's candidates leave out the departures the compare report marks "not checked against
  this scenario" (counted, not said to apply);
- a robot spawned in the air "starts in the air" and has no peak below its spawn height.

Real engines where a run is needed: tests/compare/data/racecar-drop.toml (pybullet_data's
racecar spawned at z 0.2), 0.5 s, ensembles of 2, in this process (workers=0).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from _engines import require_backend

from simbridge.cli import main
from simbridge.compare import compare, load_scenario
from simbridge.compare.analysis.events import engine_events
from simbridge.compare.errors import EngineNotInStudyError, ScenarioError
from simbridge.compare.report.departures import NOT_CHECKED, applicable
from simbridge.compare.report.events import event_words
from simbridge.compare.report.summary_json import event_dict
from simbridge.compare.study import explain, parse_vary, sweep
from simbridge.compare.study.explain import candidates, not_checked
from simbridge.exceptions import InvalidArgumentError, InvalidProfileError
from simbridge.profiles import get_profile

DATA = Path(__file__).parents[1] / "data"
RACECAR = DATA / "racecar-drop.toml"
TWO = ["pybullet", "mujoco"]
WITH_PHYSX = ["pybullet", "physx"]  # PhysX lists departures no rule checks (spherical joints...)
SMALL = dict(duration=0.5, ensemble=2, workers=0, cache=False)


# ---------------------------------------------------------------- an engine not in the study


def test_a_setting_of_an_engine_not_run_is_refused_before_any_run():
    for call in (
        lambda: compare(
            RACECAR, TWO, engine_settings={"physx": {"contact_offset": 0.001}}, **SMALL
        ),
        lambda: sweep(RACECAR, TWO, ["physx.contact_offset=0.001,0.002"], **SMALL),
        lambda: sweep(
            RACECAR,
            TWO,
            ["lateral_friction=0.5,0.9"],
            engine_settings={"physx": {"contact_offset": 0.001}},
            **SMALL,
        ),
        lambda: explain(
            RACECAR, TWO, engine_settings={"physx": {"contact_offset": 0.001}}, **SMALL
        ),
    ):
        with pytest.raises(EngineNotInStudyError) as info:
            call()
        err = info.value
        assert isinstance(err, InvalidArgumentError)  # a bad argument, as the others
        assert (err.backend, err.setting, err.engines) == (
            "physx",
            "physx.contact_offset",
            TWO,
        )
        assert "'physx'" in str(err) and "'pybullet', 'mujoco'" in str(err)
    # KEY@N past the engines, or naming another backend's slot, before the first point runs
    with pytest.raises(InvalidArgumentError, match="there are 2 engines"):
        sweep(RACECAR, TWO, ["restitution=0.1", "lateral_friction@5=0.5"], **SMALL)
    with pytest.raises(InvalidArgumentError, match="engine 1 is 'pybullet', not 'mujoco'"):
        sweep(RACECAR, TWO, ["mujoco.impratio@1=1,10"], **SMALL)


def test_a_scenarios_own_table_for_an_engine_not_run_is_accepted(tmp_path):
    text = RACECAR.read_text() + "\n[engines.physx]\ncontact_offset = 0.002\n"
    path = tmp_path / "racecar-physx-table.toml"
    path.write_text(text.replace('urdf = "racecar/', f'urdf = "{_pybullet_data()}/racecar/'))
    sc = load_scenario(path)
    assert sc.engine("physx") == {"contact_offset": 0.002}
    c = compare(sc, TWO, **SMALL)  # a scenario is written for every engine: runs
    assert c.backends == tuple(TWO)


def _pybullet_data() -> str:
    import pybullet_data

    return pybullet_data.getDataPath()


def _cli(argv, capsys):
    code = main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def test_cli_says_it_as_bad_usage(capsys, tmp_path):
    base = [str(RACECAR), "--backends", *TWO, "--duration", "0.5", "--ensemble", "2"]
    base += ["--out", str(tmp_path / "r"), "--workers", "0"]
    for argv in (
        ["sweep", *base, "--vary", "physx.contact_offset=0.001,0.002"],
        ["compare", *base, "--set", "physx.contact_offset=0.001"],
        ["explain", *base, "--set", "physx.contact_offset=0.001"],
    ):
        code, out, err = _cli(argv, capsys)
        assert code == 2, err
        assert err.startswith("usage: simbridge ")
        assert "physx.contact_offset is a setting of 'physx'" in err
        assert "'pybullet', 'mujoco'" in err and out == ""
    # --vary KEY@N past the engines: usage and exit 2, as KEY@0 (argparse's own) is
    for slot in ("0", "5"):
        code, _, err = _cli(["sweep", *base, "--vary", f"lateral_friction@{slot}=0.5"], capsys)
        assert code == 2 and err.startswith("usage: simbridge sweep"), err
        assert "argument --vary: " in err
    assert not (tmp_path / "r").exists()  # nothing ran, no report folder


# ---------------------------------------------------------------- did you mean


def test_did_you_mean_for_keys_profiles_and_settings(tmp_path, capsys):
    path = tmp_path / "typo.toml"
    path.write_text(RACECAR.read_text().replace("position = [", "base_position = ["))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    msg = str(info.value)
    assert "robots[1].base_position" in msg and "did you mean 'position'?" in msg
    assert "PyBullet's base_position" in msg and ":17:" in msg  # the key's line
    path.write_text(RACECAR.read_text().replace("position = [", "positon = ["))
    with pytest.raises(ScenarioError, match=r"did you mean 'position'\?"):
        load_scenario(path)
    path.write_text(RACECAR.read_text().replace('timestep = "1/240"', "timeStep = 0.004"))
    with pytest.raises(ScenarioError, match=r"did you mean 'timestep'\?"):
        load_scenario(path)
    with pytest.raises(InvalidProfileError, match=r"'pybulet' \(did you mean 'pybullet'\?\)"):
        get_profile("pybulet")
    with pytest.raises(InvalidArgumentError, match=r"did you mean 'lateral_friction'\?"):
        parse_vary("lateral_fricton=0.5")
    with pytest.raises(
        InvalidProfileError, match=r"impratoi: unknown setting \(did you mean 'impratio'\?\)"
    ):
        parse_vary("mujoco.impratoi=1,10")
    code, _, err = _cli(
        ["sweep", str(RACECAR), "--profile", "pybulet", "--vary", "restitution=0.1"], capsys
    )
    assert code == 2 and "did you mean 'pybullet'?" in err
    code, _, err = _cli(["sweep", str(RACECAR), "--vary", "lateral_fricton=0.5"], capsys)
    assert code == 2 and "did you mean 'lateral_friction'?" in err
    # an invalid scenario file is the file's error, not the command line's: exit 1, no usage
    path.write_text(RACECAR.read_text().replace("position = [", "base_position = ["))
    code, _, err = _cli(["compare", str(path), "--backends", *TWO], capsys)
    assert code == 1 and not err.startswith("usage:") and "did you mean 'position'?" in err


# ---------------------------------------------------------------- a racecar dropped


@pytest.fixture(scope="module")
def dropped():
    require_backend("physx")
    return compare(RACECAR, WITH_PHYSX, **SMALL)


def test_explain_leaves_out_the_departures_not_checked_here(dropped):
    deps = applicable(dropped, engine_events(dropped))  # as explain() finds them
    marked = {
        d["key"] for lab in dropped.labels for d in deps[lab]["apply"] if d["why"] == NOT_CHECKED
    }
    assert marked, "the backends list departures no rule checks (spherical joints...)"
    labels = (dropped.labels[0], dropped.labels[1])
    cands, not_tested = candidates(tuple(WITH_PHYSX), tuple(dropped.profiles), labels, deps)
    assert not marked & {k for k, _ in not_tested}  # not said to apply
    assert set(not_checked(labels, deps)) == marked  # counted instead
    # the racecar: revolute and fixed joints only, no teleports; the compare report's
    # departures that apply here (contact, its cylinders) are still the candidates' source
    assert {"spherical joints", "snapshot", "self collision", "meshes"} <= marked
    # PhysX's float32 state applies to every scenario: said to apply, and no setting moves it
    assert "precision" not in marked and "cylinder" in {k for k, _ in not_tested}
    assert "precision" in {k for k, _ in not_tested}
    assert any(c.source == "departure: contact" for c in cands)
    # link damping is checked: it applies where a profile damps (pybullet's does), a candidate
    assert "link damping" not in marked
    assert "link damping" in [c.name for c in cands]


def test_explain_report_counts_them(tmp_path):
    from simbridge.compare.study import write_explanation

    require_backend("physx")
    # PhysX's car given a heavy link damping: it falls slower, a gap of 5.3 cm at 0.2 s (measured)
    damped = ["pybullet", "pybullet+linear_damping=3.0"]
    e = explain(RACECAR, WITH_PHYSX, profile=damped, **{**SMALL, "duration": 0.3})
    path = write_explanation(e, tmp_path, plots=False)
    text = Path(path).read_text()
    for key in ("spherical joints", "self collision", "snapshot", "meshes"):
        assert f"(departure: {key})" not in text  # not said to apply
    # PhysX's float32 state applies to every scenario: said to apply, and no setting moves it
    assert "| (departure: precision) | not tested | departure applies |" in text
    (p,) = e.pairs
    assert not p.note and p.ranked[0].candidate.name == "linear_damping"  # a gap, explained
    assert {"spherical joints", "snapshot", "meshes"} <= set(p.not_checked)
    assert not set(p.not_checked) & {d for d, _ in p.not_tested}
    n = len(p.not_checked)
    assert f"Left out: {n} departures the engines list but that are not checked against" in text
    assert "spherical joints" in text.split("Left out:", 1)[1].split("\n", 1)[0]
    assert e.as_dict()["pairs"][0]["not_checked"] == p.not_checked


def test_a_robot_spawned_in_the_air_starts_in_the_air(dropped):
    for e in engine_events(dropped):
        first = e.events[0]
        assert first.kind == "airborne" and first.figures.get("from_start") == 1.0
        assert 0.1 < first.figures["duration"] < 0.3  # about sqrt(2 x 0.2 / 9.8) s
        words = event_words({**event_dict(first), "label": e.label}, e.label)
        assert words.startswith(f"{e.label}'s car starts in the air (falls for ")
        assert "left the ground" not in words
        peaks = [x for x in e.events if x.kind == "peak_height" and x.time <= first.time + 0.3]
        assert peaks == []  # falling from the spawn height is not a peak
