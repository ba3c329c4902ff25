"""Ensembles and the verdict on real engines, and the command line's --ensemble, --perturb,
--seed.

Measured verdicts (PyBullet 3.2.7, MuJoCo 4.0, 1/240 s): the pendulum agrees (gap 1e-9 m); on
r2d2-gentle the engines differ (7.2 cm, spreads 1e-4 m and 1e-9 m); the balanced pendulum
(tests/compare/data) is chaotic on whichever engine runs it under the "urdf" profile (nothing
holds it up) and still on the other (the "pybullet" profile's brake holds it).
"""

from __future__ import annotations

import json
import logging
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _held import held_scenario, wait_for_holding
from _precision import float32
from _procs import alive, children

from simbridge.cli import main
from simbridge.compare import compare, report
from simbridge.compare.report import summary as compare_summary
from simbridge.compare.run.ensemble import run_ensembles
from simbridge.compare.scenario import load_scenario
from simbridge.exceptions import InvalidArgumentError

BALANCED = Path(__file__).parents[1] / "data" / "balanced-pendulum.toml"
DOCS = Path(__file__).resolve().parents[3] / "docs" / "compare.md"


def test_pendulum_agrees(other):
    c = compare("pendulum", ["pybullet", other], ensemble=4)
    v = c.verdict
    assert v.verdict == "agree" and not v.marginal, v
    # PhysX (float32) against PyBullet measured 1.18e-6 m: its rounding over the swing
    assert v.max_gap[0] < (5e-6 if float32(other) else 1e-6) and v.test is None
    # a float32 engine is perturbed at 9.5e-7 m here (8 float32 spacings at the spawn's 1 m):
    # its spread is that size; PhysX measured 1.18e-6
    for e, name in zip(v.per_engine, ["pybullet", other], strict=True):
        spread = 5e-6 if float32(name) else 1e-6
        assert e.size == 4 and e.spread_end.value < spread
        assert [h for _, h in e.horizons] == [None, None, None]


def test_r2d2_gentle_differs(other):
    c = compare("r2d2-gentle", ["pybullet", other], ensemble=4)
    v = c.verdict
    assert v.verdict == "differ" and v.judged_at == "end", v
    assert 0.06 < v.gap.value < 0.08  # measured 7.18 cm
    assert v.gap.low <= v.gap.value <= v.gap.high
    # 4 + 4 runs: 70 splits; separated means p = 2/70
    assert v.test.exact and v.test.p_value == pytest.approx(2 / 70)
    for e, name in zip(v.per_engine, ["pybullet", other], strict=True):
        # measured 1.1e-4 m (PyBullet), 2e-9 m (MuJoCo), 5.2e-3 m (PhysX, float32: perturbed at
        # 2.4e-7 m, its spread grows from its own rounding)
        assert e.spread_end.value < (1e-2 if float32(name) else 1e-3)
        assert e.gap_over_spread > 2 and e.gap_over_own_error > 2


class FallsLate(Exception):
    """PhysX's balanced pendulum, released, judged "agree": the strict xfail's one outcome."""


# PhysX (float32) released without a brake ("urdf"): its balanced pendulum falls later than on
# the double-precision engines (its 6 runs' spread reaches 1 cm at 5.66 s, not 4.06 s), so in
# the scenario's 6 s the gap to the held engine stays under the 1 cm tolerance (largest 6.15e-4
# m, at 6.0 s; spread at the end 0.0448 m): verdict "agree" where "chaotic" is expected. An open
# finding. Measured (PhysX, SAPIEN 3.0.3, AVX-512 machine), the same bits under OpenBLAS's
# Haswell and Sandybridge kernels and numpy's run-time SIMD turned off; the bounds allow 10 %
# (about 0.02 s of the fall's e-folding time, 1 / 4.42 s): worse than that fails.
FALLS_LATE = {"largest gap": 6.15e-4, "spread at the end": 0.0448, "1 cm horizon": 5.6625}


def _falls_late_no_worse(request, v, fell) -> None:
    """The recorded figures, not worse (a regression fails), then the expected failure, its
    reason naming what was measured."""
    gap, spread, horizon = v.max_gap[0], fell.spread_end.value, fell.horizons[0][1]
    measured = f"largest gap {gap:.3g} m, spread {spread:.3g} m, 1 cm horizon {horizon} s"
    assert gap >= FALLS_LATE["largest gap"] / 1.1, measured
    assert spread >= FALLS_LATE["spread at the end"] / 1.1, measured
    assert horizon is not None and horizon <= FALLS_LATE["1 cm horizon"] * 1.1, measured
    why = f"judged agree: {measured} (recorded {FALLS_LATE})"
    request.node.add_marker(pytest.mark.xfail(strict=True, raises=FallsLate, reason=why), False)
    raise FallsLate(why)


@pytest.mark.parametrize("loose", [0, 1])
def test_balanced_pendulum_is_chaotic_on_the_engine_without_a_brake(
    other, loose, tmp_path, request
):
    """Measured on double-precision engines. PhysX (float32) released without a brake
    ("urdf") is a strict xfail with its size (FALLS_LATE): its 6 runs agree with the held
    engine. Held by the brake, a float32 engine's spread is its perturbation's (below)."""
    late = float32(other) and loose == 1
    if late:  # strict: a pass fails
        request.applymarker(
            pytest.mark.xfail(
                strict=True,
                raises=FallsLate,
                reason=f"{other}'s released balanced pendulum falls too late to be judged chaotic",
            )
        )
    profiles = ["pybullet", "pybullet"]
    profiles[loose] = "urdf"
    c = compare(BALANCED, ["pybullet", other], profile=profiles, ensemble=6)
    v = c.verdict
    held, fell = v.per_engine[1 - loose], v.per_engine[loose]
    if late and v.verdict == "agree":
        _falls_late_no_worse(request, v, fell)
    assert v.verdict == "chaotic", v
    assert v.engines == [c.labels[loose]]
    # nothing grows on the held engine: its spread is its members' starting offsets, 2x the
    # perturbation (measured 1.93e-9 m on PyBullet and MuJoCo, perturbed at 1e-9 m; PhysX
    # 1.82e-6 m, a float32 engine perturbed at 9.5e-7 m, as in test_pendulum_agrees)
    assert held.spread_end.value < (5e-6 if float32(["pybullet", other][1 - loose]) else 1e-6)
    assert fell.spread_end.value > 0.1 and fell.gap_over_spread < 1
    assert fell.horizons[0][1] is not None  # its spread reached 1 cm
    first = report(c, tmp_path, plots=False, trajectories=False).read_text().splitlines()[2]
    assert first.startswith(f"**{c.labels[loose]} is chaotic on this scenario**: 6 runs started")


def test_members_run_in_workers_equal_members_run_here():
    sc = load_scenario("pendulum").truncated(0.25)
    engines = [("pybullet", "pybullet"), ("mujoco", "pybullet")]
    here = run_ensembles(sc, engines, "link_distance", size=3, perturb=1e-6, workers=0)
    there = run_ensembles(sc, engines, "link_distance", size=3, perturb=1e-6, workers=2)
    for a, b in zip(here, there, strict=True):
        assert np.array_equal(a.features, b.features)
        assert np.array_equal(a.end_points, b.end_points)
        assert a.features.shape == (3, 61, 2, 3)  # members, instants, links, xyz
    # perturbed members differ from the nominal one, by about the perturbation
    d = np.abs(here[0].features[1:] - here[0].features[:1]).max()
    assert 1e-8 < d < 1e-4
    other_seed = run_ensembles(sc, engines[:1], "link_distance", size=3, perturb=1e-6, seed=1)
    assert not np.array_equal(other_seed[0].features, here[0].features)


def test_worker_log_records_reach_the_callers_log_once_each(caplog):
    """Records logged in the worker processes (here PyBullet's import banner, at DEBUG) come
    back to the caller's ``simbridge`` loggers, each distinct one once with its member count;
    at the caller's default level (WARNING) the workers send none of them."""
    sc = load_scenario("pendulum").truncated(0.05)
    engines = [("pybullet", "pybullet")]
    with caplog.at_level(logging.DEBUG, logger="simbridge"):
        run_ensembles(sc, engines, "link_distance", size=3, workers=2)
    banners = [r for r in caplog.records if "pybullet build time" in r.getMessage()]
    assert banners and all(r.name == "simbridge.pybullet" for r in banners)
    from_workers = [r.getMessage() for r in banners if "ensemble members]" in r.getMessage()]
    assert len(from_workers) == 1, from_workers  # once, however many workers printed it
    assert from_workers[0].endswith(" of 2 pybullet ensemble members]")
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="simbridge"):
        run_ensembles(sc, engines, "link_distance", size=3, workers=2)
    assert not [r for r in caplog.records if "ensemble members]" in r.getMessage()]


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"ensemble": 0}, "ensemble"),
        ({"ensemble": 2.5}, "ensemble"),
        ({"perturb": -1e-9}, "perturb"),
        ({"perturb": float("nan")}, "perturb"),
        ({"perturb": (1e-9, 1e-9, 1e-9)}, "perturb"),
        ({"seed": -1}, "seed"),
        ({"workers": -1}, "workers"),
        ({"tolerance": 0.0}, "tolerance"),
    ],
)
def test_bad_ensemble_arguments_are_refused(kw, name):
    with pytest.raises(InvalidArgumentError, match=name):
        compare("pendulum", ["pybullet", "pybullet"], duration=0.05, **kw)


def test_report_carries_the_ensemble_and_its_plot(tmp_path):
    c = compare("pendulum", ["pybullet", "mujoco"], ensemble=3, duration=0.5, seed=2)
    path = report(c, tmp_path)
    s = json.loads((tmp_path / "summary.json").read_text())
    assert (tmp_path / "ensemble.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "ensemble.png" in s["files"] and "](ensemble.png)" in path.read_text()
    e = s["ensemble"]
    assert e["size"] == 3 and e["seed"] == 2
    assert e["perturbation"] == {"position": 1e-9, "orientation": 1e-9}
    assert set(e["engines"]) == {"pybullet", "mujoco"}
    for fig in e["engines"].values():
        assert len(fig["end_points"]) == 3 and len(fig["horizons"]) == 3
    v = s["verdict"]
    assert v["verdict"] == "agree" and v["labels"] == ["pybullet", "mujoco"]
    lines = path.read_text().splitlines()
    assert lines[2].startswith("**pybullet and mujoco agree on this scenario**")
    assert "## Verdict: agree" in lines


def test_every_summary_field_is_described_in_the_docs():
    c = compare("r2d2-gentle", ["pybullet", "pybullet"], ensemble=2, duration=0.1)
    s = compare_summary(c)
    docs = DOCS.read_text()
    keys = set(s["verdict"]) | set(s["ensemble"]) | {"verdict", "ensemble"}
    keys |= set(s["verdict"]["engine_figures"]["pybullet"])
    keys |= set(next(iter(s["ensemble"]["engines"].values())))
    keys |= set(s["verdict"]["test"] or {}) | set(s["verdict"]["timeline"][0])
    missing = sorted(k for k in keys if f"`{k}`" not in docs)
    assert not missing, f"docs/compare.md does not describe {missing}"


# ---------------------------------------------------------------- command line


def test_cli_flags_reach_the_summary(tmp_path, capsys):
    out = tmp_path / "rep"
    argv = ["compare", "pendulum", "--duration", "0.25", "--no-plots", "--out", str(out)]
    argv += ["--ensemble", "3", "--perturb", "1e-6", "--seed", "7"]
    assert main(argv) == 0
    stdout = capsys.readouterr().out.splitlines()
    s = json.loads((out / "summary.json").read_text())
    assert s["ensemble"]["size"] == 3 and s["ensemble"]["seed"] == 7
    assert s["ensemble"]["perturbation"] == {"position": 1e-6, "orientation": 1e-6}
    assert s["verdict"]["verdict"] == "agree"
    # the short headline (the first pair's verdict on line 1, or line 2 under the line naming
    # three or more engines); the report says more
    assert "AGREE" in " ".join(stdout[:2]) and len(stdout) <= 6
    text = (out / "report.md").read_text()
    assert "agree on this scenario" in text and "1e-06 m / 1e-06 rad apart" in text


@pytest.mark.parametrize(
    "flag, value",
    [
        ("--ensemble", "0"),
        ("--ensemble", "many"),
        ("--perturb", "-1e-9"),
        ("--perturb", "nan"),
        ("--perturb", "inf"),
        ("--seed", "-1"),
        ("--seed", "1.5"),
    ],
)
def test_cli_bad_flag_values_exit_2(flag, value, capsys):
    assert main(["compare", "pendulum", flag, value]) == 2
    err = capsys.readouterr().err
    assert "usage: simbridge" in err and f"argument {flag}" in err


def _noise(args: list[str], out: Path) -> list[str]:
    """Lines the command prints besides its headline and report path."""
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "simbridge",
            "compare",
            "pendulum",
            "--duration",
            "0.1",
            "--no-plots",
            "--out",
            str(out),
            *args,
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    text = done.stdout + done.stderr
    from simbridge.compare.report.brief import brief

    # what the command prints on purpose: its short headline of summary.json (the paragraphs
    # are in report.md)
    keep = set(brief(json.loads((out / "summary.json").read_text()), out / "report.md"))
    return sorted(line for line in text.splitlines() if line not in keep)


def test_workers_print_nothing(tmp_path):
    alone = _noise(["--ensemble", "1"], tmp_path / "one")
    many = _noise(["--ensemble", "4"], tmp_path / "four")
    # six engine runs in worker processes add no line to what the parent itself prints
    assert many == alone


def test_a_script_read_from_stdin_runs_its_members_in_process():
    # a spawned worker would try to import "<stdin>" as the main module, and die
    script = (
        "from simbridge.compare import compare\n"
        "c = compare('pendulum', ['pybullet', 'pybullet'], ensemble=3, duration=0.1)\n"
        "print(c.verdict.verdict, c.ensemble_settings.workers, c.ensembles[0].size)\n"
    )
    done = subprocess.run(
        [sys.executable, "-"], input=script, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["agree", "0", "3"]


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)")
@pytest.mark.parametrize("when", ["starting", "running"])
def test_workers_end_when_the_command_is_killed(tmp_path, when):
    """`kill -TERM` (or -KILL) of `simbridge compare` runs no clean-up in it: its workers
    watch their parent and end within a second (they were left idle, 100 MB each), whether
    killed while the workers start or while they run members."""
    import signal
    import time

    scenario, ready = held_scenario(tmp_path)  # its runs hold: none can end before the kill
    proc = subprocess.Popen(
        [sys.executable, "-m", "simbridge", "compare", str(scenario), "--ensemble", "4",
         "--no-plots", "--out", str(tmp_path / "out")],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        workers: list[int] = []
        while time.monotonic() < deadline and len(workers) < 2:
            time.sleep(0.2)
            workers = [c for c in children(proc.pid) if alive(c)]
        assert len(workers) >= 2, "the workers did not start"
        if when == "running":  # two workers past their imports, inside a run
            workers = wait_for_holding(proc, ready, 2)
        workers = sorted(set(workers) | {c for c in children(proc.pid) if alive(c)})
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=30)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and any(map(alive, workers)):
            time.sleep(0.1)
        left = [w for w in workers if alive(w)]
        assert not left, f"workers {left} outlived the killed command"
    finally:
        if proc.poll() is None:
            proc.kill()
