"""`simbridge compare --out DIR` leaves no folder behind when the study fails or is stopped
before its report is written (it made an empty one), and never removes a folder that was
there before."""

from __future__ import annotations

from pathlib import Path

import pytest

from simbridge.cli import main

PENDULUM = (Path(__file__).resolve().parents[2] / "compare/scenarios/pendulum.toml").read_text()
ARGS = ["--backends", "pybullet", "pybullet", "--duration", "0.1", "--ensemble", "1"]
ARGS += ["--workers", "0", "--no-plots", "--no-replay"]


def _bad(tmp_path: Path) -> Path:
    path = tmp_path / "bad.toml"
    path.write_text(PENDULUM.replace('joints = "hinge"', 'joints = "hinje"', 1))
    return path


def test_a_failed_study_leaves_no_folder(tmp_path, capsys):
    out = tmp_path / "reports" / "deep" / "mine"
    assert main(["compare", str(_bad(tmp_path)), *ARGS, "--out", str(out)]) == 1
    assert "hinje" in capsys.readouterr().err
    assert not (tmp_path / "reports").exists()


@pytest.mark.parametrize("contents", [False, True])
def test_a_folder_that_was_there_stays(tmp_path, contents):
    out = tmp_path / "mine"
    out.mkdir()
    if contents:
        (out / "notes.txt").write_text("mine")
    assert main(["compare", str(_bad(tmp_path)), *ARGS, "--out", str(out)]) == 1
    assert out.is_dir()
    assert [p.name for p in out.iterdir()] == (["notes.txt"] if contents else [])


def test_a_stopped_study_leaves_no_folder(tmp_path, monkeypatch, capsys):
    import simbridge.compare as compare_module

    def stopped(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(compare_module, "compare", stopped)
    out = tmp_path / "mine"
    assert main(["compare", "pendulum", *ARGS, "--out", str(out)]) == 130
    assert "interrupted" in capsys.readouterr().err
    assert not out.exists()


@pytest.mark.parametrize(
    "study", [["sweep", "--vary", "lateral_friction=0.5,0.6"], ["explain"]], ids=lambda s: s[0]
)
def test_a_failed_sweep_or_explain_leaves_no_folder(tmp_path, capsys, study):
    out = tmp_path / "reports" / "mine"
    argv = [study[0], str(_bad(tmp_path)), *ARGS[:-2], *study[1:], "--out", str(out)]
    assert main(argv) == 1, capsys.readouterr().err
    assert "hinje" in capsys.readouterr().err
    assert not (tmp_path / "reports").exists()
