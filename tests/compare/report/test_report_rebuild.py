"""A report rebuilt from the cache (``simbridge report DIR``): the same report.md, summary.json
and pictures as the study's own, the derived entries it reuses (verdicts, figures, frames,
trajectory files) and when they are made again, and the resolve table of ``--resolve``."""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from simbridge.cli import main
from simbridge.compare.analysis.judged import judged
from simbridge.compare.report import derived as derived_module
from simbridge.compare.report import frames as frames_module
from simbridge.compare.report import plots as plots_module
from simbridge.compare.run import cache as cache_module
from simbridge.compare.run.cache import Cache, derived_key
from simbridge.compare.run.studyjobs import JobCounts

TIMING_KEYS = ("wall_time", "wall_per_sim_second", "seconds", "command_line")


def _masked(v: Any) -> Any:
    """summary.json without the timings (and the command line) that change from run to run."""
    if isinstance(v, dict):
        return {k: _masked(x) for k, x in v.items() if k not in TIMING_KEYS}
    if isinstance(v, list):
        return [_masked(x) for x in v]
    return v


def _compare(cache: Path, out: Path, *extra: str) -> None:
    argv = ["compare", "double-pendulum", "--backends", "pybullet", "pybullet"]
    argv += ["--profile", "pybullet", "pybullet+linear_damping=0.12", "--timestep", "1/30"]
    argv += ["--ensemble", "4", "--resync-every", "0", "--workers", "0"]
    assert main([*argv, "--cache", str(cache), "--out", str(out), *extra]) == 0


def _files(out: Path) -> dict[str, bytes]:
    return {
        p.relative_to(out).as_posix(): p.read_bytes()
        for p in sorted(out.rglob("*"))
        if p.is_file() and p.name not in ("summary.json", "study.json", "report.html")
    }


@pytest.fixture
def refuse_drawing(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """Drawing a figure or a frame records it (the test says whether that may happen)."""
    drawn: list[str] = []
    real_plots, real_frames = plots_module.all_plots, frames_module.write_frames

    def plots(*a: Any, **k: Any) -> Any:
        drawn.append("figures")
        return real_plots(*a, **k)

    def frames(*a: Any, **k: Any) -> Any:
        drawn.append("frames")
        return real_frames(*a, **k)

    monkeypatch.setattr(plots_module, "all_plots", plots)
    monkeypatch.setattr(frames_module, "write_frames", frames)
    return drawn


def test_rebuild_gives_the_same_report_and_reuses_the_pictures(tmp_path, refuse_drawing):
    cache, out = tmp_path / "cache", tmp_path / "rep"
    _compare(cache, out, "--no-replay")  # the 3D replay needs viser, the frames do not
    assert main(["report", str(out), "--cache", str(cache)]) == 0  # with the key frames
    assert refuse_drawing == ["figures", "frames"]
    kinds = {p.name for p in cache.iterdir()}
    assert {"jobs", "verdicts", "figures", "frames", "trajectories"} <= kinds
    before_files = _files(out)
    before = json.loads((out / "summary.json").read_text())
    assert any(name.endswith(".png") for name in before_files)
    assert "frames/replay.gif" in before_files
    for f in out.rglob("*"):  # every file written again
        if f.is_file() and f.name != "study.json":
            f.unlink()
    refuse_drawing.clear()
    assert main(["report", str(out), "--cache", str(cache)]) == 0
    assert refuse_drawing == []  # every picture from the cache
    assert _files(out) == before_files  # report.md, figures, frames, trajectories: byte for byte
    assert _masked(json.loads((out / "summary.json").read_text())) == _masked(before)


def test_a_job_entry_made_again_draws_the_pictures_again(tmp_path, refuse_drawing):
    cache, out = tmp_path / "cache", tmp_path / "rep"
    _compare(cache, out, "--no-replay")
    refuse_drawing.clear()
    assert main(["report", str(out), "--cache", str(cache), "--no-replay"]) == 0
    assert refuse_drawing == []
    # one job's result stored again with other bytes (as --fresh or an engine upgrade would):
    # its entry's sha256 changes, so does the key of every picture
    entry = sorted((cache / "jobs").rglob("*.pkl"))[0]
    data = pickle.loads(entry.read_bytes())
    data["result"].wall_time += 1.0
    Cache(cache).put(data["key"], data["result"])
    assert main(["report", str(out), "--cache", str(cache), "--no-replay"]) == 0
    assert refuse_drawing == ["figures"]


def test_other_code_draws_the_pictures_again(tmp_path, refuse_drawing, monkeypatch):
    cache, out = tmp_path / "cache", tmp_path / "rep"
    _compare(cache, out, "--no-replay")
    refuse_drawing.clear()
    monkeypatch.setattr(cache_module, "code_digest", lambda: "another version")
    assert main(["report", str(out), "--cache", str(cache), "--no-replay"]) == 0
    assert refuse_drawing == ["figures"]


def test_fresh_and_no_cache_make_everything_again(tmp_path, refuse_drawing):
    cache, out = tmp_path / "cache", tmp_path / "rep"
    _compare(cache, out, "--no-replay")
    refuse_drawing.clear()
    _compare(cache, out, "--no-replay", "--fresh")
    assert refuse_drawing == ["figures"]
    refuse_drawing.clear()
    _compare(cache, tmp_path / "other", "--no-replay", "--no-cache")
    assert refuse_drawing == ["figures"]


def test_a_verdict_is_kept_under_every_argument(tmp_path, monkeypatch):
    rng = np.random.default_rng(3)
    time = np.linspace(0.0, 1.0, 20)
    members = [rng.normal(size=(4, 20, 3)), rng.normal(size=(4, 20, 3)) + 0.5]
    own = [np.full(20, 1e-3), np.full(20, 2e-3)]
    counts = JobCounts(total=0, cached=0, ran=0, failed=0, cache=str(tmp_path))
    args = (time, "base_distance", ("a", "b"), members, own)
    first = judged(counts, *args, seed=1)
    calls: list[int] = []
    from simbridge.compare.analysis import verdict as verdict_module

    real = verdict_module.judge

    def counting(*a: Any, **k: Any) -> Any:
        calls.append(1)
        return real(*a, **k)

    monkeypatch.setattr(verdict_module, "judge", counting)
    again = judged(counts, *args, seed=1)
    assert calls == [] and again.gap == first.gap and again.verdict == first.verdict
    judged(counts, *args, seed=2)  # another seed: another bootstrap
    assert calls == [1]
    moved = [members[0].copy(), members[1]]
    moved[0][2, 7, 1] += 1e-12  # one figure of one run, by a trillionth
    judged(counts, time, "base_distance", ("a", "b"), moved, own, seed=1)
    assert calls == [1, 1]
    judged(counts, *args, seed=1, tolerance=0.5)
    assert calls == [1, 1, 1]
    counts.fresh = True
    judged(counts, *args, seed=1)
    assert calls == [1, 1, 1, 1]
    assert len(list((tmp_path / "verdicts").rglob("*.pkl"))) == 4


def test_derived_keys_see_arrays_by_content():
    a = np.arange(6.0)
    assert derived_key("figures", a) == derived_key("figures", a.copy())
    assert derived_key("figures", a) != derived_key("figures", a.reshape(2, 3))
    assert derived_key("figures", a) != derived_key("figures", a.astype(np.float32))
    assert derived_key("figures", a) != derived_key("frames", a)
    assert derived_module.report_key(object(), "figures") is None  # no study: none


def test_rebuild_keeps_the_resolve_table(tmp_path, capsys):
    cache, out = tmp_path / "cache", tmp_path / "rep"
    _compare(cache, out, "--no-plots", "--no-replay", "--resolve-limit", "1")
    recorded = json.loads((out / "study.json").read_text())
    steps = recorded["resolve"]["summary"]["steps"]
    assert [s["timestep"] for s in steps] == [1 / 30, 1 / 60]
    md = (out / "report.md").read_text()
    summary = json.loads((out / "summary.json").read_text())
    assert "## Resolve: the verdict at each time step" in md
    assert "\n".join(recorded["resolve"]["markdown"]) in md
    assert summary["resolve"] == recorded["resolve"]["summary"]
    assert main(["report", str(out), "--cache", str(cache), "--no-plots", "--no-replay"]) == 0
    assert (out / "report.md").read_text() == md  # the wall times are the recorded ones
    again = json.loads((out / "summary.json").read_text())
    assert again["resolve"] == summary["resolve"]
    assert _masked(again) == _masked(summary)
    assert json.loads((out / "study.json").read_text())["resolve"] == recorded["resolve"]
    # the table's timings are the study's own, not the rebuild's
    assert steps[0]["wall_time"] > 0


def test_a_study_json_without_resolve_rebuilds_without_the_table(tmp_path):
    cache, out = tmp_path / "cache", tmp_path / "rep"
    _compare(cache, out, "--no-plots", "--no-replay")
    assert "resolve" not in json.loads((out / "study.json").read_text())
    assert main(["report", str(out), "--cache", str(cache), "--no-plots", "--no-replay"]) == 0
    assert "## Resolve" not in (out / "report.md").read_text()


def test_judged_without_a_cache_judges_here(monkeypatch):
    counts = JobCounts(total=0, cached=0, ran=0, failed=0, cache=None)
    rng = np.random.default_rng(0)
    m = [rng.normal(size=(3, 5, 3)), rng.normal(size=(3, 5, 3))]
    v = judged(counts, np.arange(5.0), "base_distance", ("a", "b"), m, [np.ones(5)] * 2)
    assert v.labels == ("a", "b")


def test_the_rebuild_bench_runs(tmp_path):
    """bench/rebuild.py on a small study prints its rows and phases (speed not asserted)."""
    root = Path(__file__).resolve().parents[3]
    cache, out = tmp_path / "cache", tmp_path / "rep"
    _compare(cache, out, "--no-replay")
    done = subprocess.run(
        [sys.executable, str(root / "bench" / "rebuild.py"), "--folder", str(out)]
        + ["--cache", str(cache), "--repeat", "1"],
        capture_output=True,
        text=True,
        timeout=600,
        env={**os.environ, "HOME": str(tmp_path)},
    )
    assert done.returncode == 0, done.stderr
    for row in ("cold (no derived entries)", "warm", "imports", "verdicts", "figures"):
        assert row in done.stdout


def test_engines_left_out_stay_in_the_report_rebuild_after_rebuild(tmp_path):
    cache, out = tmp_path / "cache", tmp_path / "rep"
    _compare(cache, out, "--no-plots", "--no-replay")
    path = out / "study.json"
    record = json.loads(path.read_text())
    record["left_out"] = {"nosuch": "not installed here"}  # as a study of every engine records
    path.write_text(json.dumps(record))
    for _ in range(2):
        argv = ["report", str(out), "--cache", str(cache), "--no-plots", "--no-replay"]
        assert main(argv) == 0
        assert json.loads(path.read_text())["left_out"] == {"nosuch": "not installed here"}
        assert "nosuch" in (out / "report.md").read_text()
