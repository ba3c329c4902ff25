"""A comparison's runs as cached jobs: job keys, the cache, a rerun that runs nothing,
``fresh``, ``simbridge report DIR`` from the cache alone, a corrupt and a missing entry, and
failed ensemble members carried into the report."""

from __future__ import annotations

import json
import logging
import os
import pickle
import shutil
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest

import simbridge
from simbridge.cli import main
from simbridge.compare import compare, load_scenario, report
from simbridge.compare.errors import CacheEntryMissingError
from simbridge.compare.run import jobs as jobs_module
from simbridge.compare.run import studyjobs
from simbridge.compare.run.cache import Cache, default_dir
from simbridge.compare.run.jobs import Job, run_job

pytestmark = pytest.mark.usefixtures("_no_home_cache_writes")

SMALL: dict[str, Any] = {"duration": 0.2, "ensemble": 2, "workers": 0, "resync_every": 10}
BACKENDS = ["pybullet", "mujoco"]


def _figures(summary: dict[str, Any]) -> dict[str, Any]:
    """summary.json without what changes from run to run (wall times, worker count)."""

    def mask(v: Any) -> Any:
        if isinstance(v, dict):
            return {
                k: mask(x)
                for k, x in v.items()
                if k not in ("wall_time", "wall_per_sim_second", "text", "command_line")
            }
        if isinstance(v, list):
            return [mask(x) for x in v]
        return v

    return mask(summary)


@pytest.fixture
def no_stepping(monkeypatch: pytest.MonkeyPatch) -> None:
    """Any engine step in this process fails the test."""

    def refuse(*_a: Any, **_k: Any) -> None:
        raise AssertionError("an engine stepped")

    monkeypatch.setattr(simbridge.Sim, "step", refuse)


def test_default_cache_folder_follows_xdg(monkeypatch, tmp_path):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert default_dir() == tmp_path / "simbridge"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert default_dir() == Path.home() / ".cache" / "simbridge"


def test_job_key_is_its_content(tmp_path):
    sc = load_scenario("pendulum").truncated(0.1)
    job = Job.of("nominal", sc, "pybullet", "pybullet")
    assert Job.of("nominal", sc, "pybullet", "pybullet").key == job.key
    assert pickle.loads(pickle.dumps(job)).key == job.key
    others = [
        Job.of("half-step", sc, "pybullet", "pybullet"),
        Job.of("nominal", sc, "mujoco", "pybullet"),
        Job.of("nominal", sc, "pybullet", "urdf"),
        Job.of("nominal", sc, "pybullet", simbridge.get_profile("pybullet").with_(restitution=0.1)),
        Job.of("nominal", sc.with_timestep(1 / 480), "pybullet", "pybullet"),
        Job.of("nominal", sc, "pybullet", "pybullet", member=1),
        Job.of("nominal", replace(sc, gravity=(0.0, 0.0, -9.7)), "pybullet", "pybullet"),
    ]
    assert len({j.key for j in others} | {job.key}) == len(others) + 1
    # the robot file's content is in the key, not its place
    from simbridge.model.urdf_source import resolve_source

    urdf = resolve_source(sc.resolve_urdf(sc.robots[0])).path
    assert urdf is not None
    for name in ("a", "b"):
        (tmp_path / name).mkdir()
        shutil.copy(urdf, tmp_path / name / "robot.urdf")
    robots = (replace(sc.robots[0], urdf="robot.urdf"),)
    a = replace(sc, robots=robots, source=tmp_path / "a" / "s.toml")
    b = replace(sc, robots=robots, source=tmp_path / "b" / "s.toml")
    assert Job.of("nominal", a, "pybullet", "pybullet").key == (
        Job.of("nominal", b, "pybullet", "pybullet").key
    )
    text = (tmp_path / "b" / "robot.urdf").read_text()
    (tmp_path / "b" / "robot.urdf").write_text(text.replace("<robot", "<!-- moved -->\n<robot", 1))
    assert Job.of("nominal", a, "pybullet", "pybullet").key != (
        Job.of("nominal", b, "pybullet", "pybullet").key
    )


def test_job_key_sees_the_code_that_runs_it(monkeypatch):
    """Another checkout's backend (the cache is shared by every checkout of a user) or another
    engine version makes another key: the key holds run_code_digest, which reads simbridge's
    run code and the engines' versions, not its report code."""
    from simbridge.compare.run import jobs as jobs_module

    sc = load_scenario("pendulum").truncated(0.1)
    key = Job.of("nominal", sc, "pybullet", "pybullet").key
    digest = jobs_module.run_code_digest()
    jobs_module.run_code_digest.cache_clear()
    assert jobs_module.run_code_digest() == digest  # read again: the same files, same digest
    monkeypatch.setattr(jobs_module, "run_code_digest", lambda: "an edited backend")
    assert Job.of("nominal", sc, "pybullet", "pybullet").key != key


def test_cache_put_get_and_a_corrupt_entry(tmp_path, caplog):
    cache = Cache(tmp_path / "c")
    key = "ab" * 32
    assert cache.get(key) is None
    cache.put(key, {"x": [1.5, 2]})
    assert cache.get(key) == {"x": [1.5, 2]}
    cache.path(key).write_bytes(b"not a pickle")
    with caplog.at_level(logging.WARNING, logger="simbridge.compare.cache"):
        assert cache.get(key) is None
    assert "unreadable" in caplog.text and key in caplog.text
    assert not cache.path(key).exists()
    with pytest.raises(Exception):  # noqa: B017 - whatever pickling raises
        cache.put(key, lambda: None)  # not picklable: nothing written, no temporary file left
    assert not cache.path(key).exists()
    assert [p.name for p in cache.path(key).parent.iterdir()] == []


def test_a_job_runs_here_and_gives_its_trajectory():
    sc = load_scenario("pendulum").truncated(0.05)
    result = run_job(Job.of("nominal", sc, "pybullet", "pybullet"))
    assert result.kind == "nominal" and result.value.steps == sc.steps
    assert result.pid == os.getpid()


def test_a_rerun_runs_no_job_and_gives_the_same_figures(tmp_path, monkeypatch):
    cache = tmp_path / "cache"
    first = compare("pendulum", BACKENDS, cache=cache, **SMALL)
    assert first.jobs is not None
    # 2 engines x (dt, dt/2) + 2 resync + 2 members
    assert (first.jobs.total, first.jobs.ran, first.jobs.cached) == (8, 8, 0)
    assert len(list((cache / "jobs").rglob("*.pkl"))) == 8
    calls = []
    real = jobs_module.run_job

    def counted(job):
        calls.append(job.key)
        return real(job)

    monkeypatch.setattr(jobs_module, "run_job", counted)  # what a study's worker calls
    again = compare("pendulum", BACKENDS, cache=cache, **SMALL)
    assert calls == [] and again.jobs is not None
    assert (again.jobs.ran, again.jobs.cached) == (0, 8)
    a, b = tmp_path / "a", tmp_path / "b"
    report(first, a, plots=False, trajectories=False, replay=False)
    report(again, b, plots=False, trajectories=False, replay=False)
    sa = json.loads((a / "summary.json").read_text())
    sb = json.loads((b / "summary.json").read_text())
    assert _figures(sa) == _figures(sb)
    # fresh: every job runs again, and the entries are rewritten
    fresh = compare("pendulum", BACKENDS, cache=cache, fresh=True, **SMALL)
    assert len(calls) == 8 and fresh.jobs is not None and fresh.jobs.ran == 8
    # no cache: every job runs, nothing is stored
    none = compare("pendulum", BACKENDS, cache=False, **SMALL)
    assert len(calls) == 16 and none.jobs is not None and none.jobs.cache is None


def test_a_corrupt_entry_is_run_again(tmp_path, caplog):
    cache = tmp_path / "cache"
    compare("pendulum", BACKENDS, cache=cache, **SMALL)
    entry = sorted((cache / "jobs").rglob("*.pkl"))[0]
    entry.write_bytes(entry.read_bytes()[:50])  # cut short
    with caplog.at_level(logging.WARNING, logger="simbridge.compare.cache"):
        again = compare("pendulum", BACKENDS, cache=cache, **SMALL)
    assert again.jobs is not None and (again.jobs.ran, again.jobs.cached) == (1, 7)
    assert entry.name in caplog.text


def _cli_compare(cache: Path, out: Path) -> int:
    return main(
        [
            "compare",
            "pendulum",
            "--backends",
            *BACKENDS,
            "--duration",
            "0.2",
            "--ensemble",
            "2",
            "--workers",
            "0",
            "--resync-every",
            "10",
            "--cache",
            str(cache),
            "--out",
            str(out),
        ]
    )


@pytest.fixture
def study(tmp_path: Path) -> tuple[Path, Path]:
    """A small study run through the command line: (its cache, its report folder)."""
    cache, out = tmp_path / "cache", tmp_path / "report"
    assert _cli_compare(cache, out) == 0
    return cache, out


def test_report_from_the_cache_runs_no_engine(study, no_stepping, capsys):
    cache, out = study
    before = json.loads((out / "summary.json").read_text())
    md_before = (out / "report.md").read_text()
    recorded = json.loads((out / "study.json").read_text())
    assert len(recorded["jobs"]) == 8 and recorded["arguments"]["ensemble"] == 2
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert pngs  # the figures are rebuilt too
    for name in ("summary.json", "report.md", *pngs):
        (out / name).unlink()
    assert main(["report", str(out), "--cache", str(cache)]) == 0
    after = json.loads((out / "summary.json").read_text())
    assert _figures(after) == _figures(before)
    assert (out / "report.md").read_text() == md_before
    assert sorted(p.name for p in out.glob("*.png")) == pngs
    assert json.loads((out / "study.json").read_text())["jobs"] == recorded["jobs"]


def test_report_names_a_missing_entry(study, no_stepping, capsys):
    cache, out = study
    victim = sorted((cache / "jobs").rglob("*.pkl"))[3]
    victim.unlink()
    capsys.readouterr()
    assert main(["report", str(out), "--cache", str(cache)]) == 1
    err = capsys.readouterr().err
    assert "1 of 8 jobs of the study are not in the cache" in err and str(cache) in err
    from simbridge.compare.report.rebuild import rebuild

    with pytest.raises(CacheEntryMissingError) as info:
        rebuild(out, cache=cache)
    assert info.value.key == victim.stem and (info.value.missing, info.value.total) == (1, 8)


def test_report_of_a_folder_without_a_study(tmp_path, capsys):
    assert main(["report", str(tmp_path)]) == 1
    assert "study.json" in capsys.readouterr().err


def test_failed_members_are_carried_into_the_report(tmp_path, monkeypatch):
    real = studyjobs.run_all

    def one_member_dies(fn, items, *, on_result=None, **kw):
        """mujoco's members as if each had killed its worker twice (run_all's JobFailed: no
        on_result for them)."""

        def dies(job):
            return job.kind == "member" and job.backend == "mujoco"

        def relay(i, result):
            if not dies(items[i]):
                on_result(i, result)

        out = real(fn, items, on_result=relay, **kw)
        return [
            studyjobs.JobFailed(j.label, "SIGSEGV", 2) if dies(j) else r
            for j, r in zip(items, out, strict=True)
        ]

    monkeypatch.setattr(studyjobs, "run_all", one_member_dies)
    cache = tmp_path / "cache"
    c = compare("pendulum", BACKENDS, cache=cache, **{**SMALL, "ensemble": 3})
    assert [f.cause for f in c.failed] == ["SIGSEGV", "SIGSEGV"]
    assert c.ensembles[1].size == 1 and c.ensembles[0].size == 3
    assert c.jobs is not None and c.jobs.failed == 2
    out = tmp_path / "r"
    report(c, out, plots=False, trajectories=False, replay=False)
    s = json.loads((out / "summary.json").read_text())
    assert s["ensemble"]["engines"]["mujoco"]["failed"] == {
        "members": 2,
        "judged_on": 1,
        "causes": ["SIGSEGV"],
    }
    assert "failed" not in s["ensemble"]["engines"]["pybullet"]
    assert "2 of 3 mujoco runs failed: SIGSEGV; judged on 1." in (out / "report.md").read_text()
    # a failed job is not cached: the next study runs it
    monkeypatch.setattr(studyjobs, "run_all", real)
    again = compare("pendulum", BACKENDS, cache=cache, **{**SMALL, "ensemble": 3})
    assert again.jobs is not None and again.jobs.ran == 2 and not again.failed


def test_the_jobs_bench_runs(tmp_path):
    """bench/jobs.py on a 2-run ensemble of one engine prints its rows, the pool started for
    the jobs and the pool kept from it, each with the jobs' CPU (speed not asserted)."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[3]
    done = subprocess.run(
        [sys.executable, str(root / "bench" / "jobs.py"), "--size", "2", "--backends", "mujoco"]
        + ["--no-rebuild", "--cache", str(tmp_path / "cache")],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    rows = [line.split() for line in done.stdout.splitlines() if line.startswith("mujoco")]
    assert [r[1:4] for r in rows] == [["2", "2", "cold"], ["2", "2", "warm"]], done.stdout
    assert all(float(r[9]) > 0 and float(r[10]) > 0 for r in rows)  # CPU per job, each mode
    assert len(list((tmp_path / "cache" / "jobs").rglob("*.pkl"))) == 2


def test_ctrl_c_keeps_what_finished_in_the_cache(tmp_path, monkeypatch):
    """run_all delivers every finished job before raising KeyboardInterrupt: those are cached,
    and the next study runs only the others."""
    real = studyjobs.run_all

    def interrupted(fn, items, *, on_result=None, **kw):
        def relay(i, result):
            on_result(i, result)
            if i == 2:
                raise KeyboardInterrupt

        return real(fn, items, on_result=relay, **kw)

    monkeypatch.setattr(studyjobs, "run_all", interrupted)
    cache = tmp_path / "cache"
    with pytest.raises(KeyboardInterrupt):
        compare("pendulum", BACKENDS, cache=cache, **SMALL)
    assert len(list((cache / "jobs").rglob("*.pkl"))) == 3
    monkeypatch.setattr(studyjobs, "run_all", real)
    again = compare("pendulum", BACKENDS, cache=cache, **SMALL)
    assert again.jobs is not None and (again.jobs.cached, again.jobs.ran) == (3, 5)


def test_an_exception_of_a_run_pickles_back_to_its_type():
    from simbridge.compare.errors import ScenarioError
    from simbridge.compare.run.jobs import _portable

    exc = ScenarioError("s.toml", "phases[0].steps", "must be > 0", 3)
    _portable(exc)
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is ScenarioError and str(back) == str(exc) and back.line == 3
