"""The cache's size and pruning: ``Cache.info``, ``Cache.prune`` (least recently used first, a
read marks an entry used), ``simbridge cache info`` and ``simbridge cache prune``, on a real
cache folder with entries of known sizes and last uses."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from simbridge.cli import main
from simbridge.compare.run.cache import STALE_TEMPORARY, Cache, parse_size
from simbridge.exceptions import InvalidArgumentError

DAY = 86400.0
NOW = 2_000_000_000.0  # the clock of these tests (s since the epoch)


def _key(i: int) -> str:
    return f"{i:064x}"


def _cache(tmp_path: Path, ages_days: list[float], now: float = NOW) -> tuple[Cache, list[Path]]:
    """Entries 0, 1, ... last used ``ages_days`` before ``now``, each of the same size."""
    cache = Cache(tmp_path / "cache")
    paths = []
    for i, age in enumerate(ages_days):
        path = cache.put(_key(i), {"payload": b"x" * 1000, "i": i})
        os.utime(path, (now - age * DAY, now - age * DAY))
        paths.append(path)
    return cache, paths


def test_info_counts_sizes_and_uses(tmp_path):
    cache, paths = _cache(tmp_path, [5, 1, 3])
    cache.put(_key(9), "a verdict", "verdicts")
    os.utime(cache.path(_key(9), "verdicts"), (NOW - 2 * DAY, NOW - 2 * DAY))
    info = cache.info()
    assert info.entries == 4
    assert (
        info.size
        == sum(p.stat().st_size for p in paths) + cache.path(_key(9), "verdicts").stat().st_size
    )
    assert (info.oldest, info.newest) == (NOW - 5 * DAY, NOW - 1 * DAY)
    assert info.kinds == {"jobs": 3, "verdicts": 1}
    assert Cache(tmp_path / "none").info().entries == 0


def test_prune_older_than_removes_only_the_old(tmp_path):
    cache, paths = _cache(tmp_path, [10, 1, 8, 2])
    done = cache.prune(older_than=7, now=NOW)
    assert sorted(done.removed) == sorted([paths[0], paths[2]])
    assert [p.exists() for p in paths] == [False, True, False, True]
    assert done.kept == 2 and done.freed == 2 * paths[1].stat().st_size
    assert cache.get(_key(1)) is not None and cache.get(_key(0)) is None


def test_prune_max_size_removes_the_least_recently_used_first(tmp_path):
    cache, paths = _cache(tmp_path, [4, 1, 3, 2])
    size = paths[0].stat().st_size
    done = cache.prune(max_size=2 * size, now=NOW)
    assert done.removed == [paths[0], paths[2]]  # the oldest uses first
    assert [p.exists() for p in paths] == [False, True, False, True]
    assert done.kept_size == 2 * size
    assert cache.prune(max_size=0, now=NOW).kept == 0
    assert not any((cache.dir / "jobs").iterdir())  # the emptied shard folders too


def test_a_read_marks_an_entry_used(tmp_path):
    before = time.time()
    cache, paths = _cache(tmp_path, [4, 1, 3], now=before)
    assert cache.get(_key(0)) == {"payload": b"x" * 1000, "i": 0}  # the oldest, read now
    assert paths[0].stat().st_mtime >= before - 1
    size = paths[0].stat().st_size
    done = cache.prune(max_size=size, now=time.time())
    assert paths[0].exists() and done.kept == 1  # the one just read stays


def test_dry_run_removes_nothing(tmp_path):
    cache, paths = _cache(tmp_path, [10, 1])
    done = cache.prune(older_than=5, dry_run=True, now=NOW)
    assert done.removed == [paths[0]] and done.dry_run
    assert all(p.exists() for p in paths)


def test_stale_temporary_files_go(tmp_path):
    cache, paths = _cache(tmp_path, [1])
    stale = paths[0].parent / f".{_key(0)[:16]}.abc.tmp"
    fresh = paths[0].parent / f".{_key(0)[:16]}.def.tmp"
    for f, age in ((stale, STALE_TEMPORARY + 10), (fresh, 10.0)):
        f.write_bytes(b"cut short")
        os.utime(f, (NOW - age, NOW - age))
    assert cache.info().entries == 1  # a temporary file is no entry
    done = cache.prune(older_than=30, now=NOW)
    assert done.removed == [stale]
    assert not stale.exists() and fresh.exists() and paths[0].exists()


@pytest.mark.parametrize(
    ("kwargs", "argument"),
    [
        ({}, "older_than"),
        ({"older_than": -1}, "older_than"),
        ({"older_than": float("nan")}, "older_than"),
        ({"older_than": True}, "older_than"),
        ({"max_size": -5}, "max_size"),
        ({"max_size": 1.5}, "max_size"),
    ],
)
def test_prune_rejects_bad_arguments(tmp_path, kwargs, argument):
    cache, paths = _cache(tmp_path, [100])
    with pytest.raises(InvalidArgumentError) as info:
        cache.prune(**kwargs)
    assert info.value.argument == argument
    assert paths[0].exists()


def test_parse_size():
    assert parse_size("4096") == 4096
    assert parse_size("100K") == 100 * 1024
    assert parse_size("1.5GB") == int(1.5 * 1024**3)
    assert parse_size("200mib") == 200 * 1024**2
    for bad in ("", "-1M", "12Q", "lots", "nanM"):
        with pytest.raises(InvalidArgumentError, match="500M"):
            parse_size(bad)


def test_a_derived_kind_must_be_known(tmp_path):
    with pytest.raises(InvalidArgumentError, match="verdicts"):
        Cache(tmp_path).path(_key(1), "nonsense")


def test_cli_info_and_prune(tmp_path, capsys):
    cache, paths = _cache(tmp_path, [40, 1, 20], now=time.time())  # the CLI's clock is real
    assert main(["cache", "info", "--cache", str(cache.dir)]) == 0
    out = capsys.readouterr().out
    assert f"cache: {cache.dir}" in out and "entries: 3 (jobs 3)" in out
    assert "40.0 days ago" in out and "1.0 days ago" in out
    argv = ["cache", "prune", "--cache", str(cache.dir), "--older-than", "30"]
    assert main([*argv, "--dry-run"]) == 0
    assert "would remove 1 entries" in capsys.readouterr().out and paths[0].exists()
    assert main(argv) == 0
    assert "removed 1 entries" in capsys.readouterr().out and not paths[0].exists()
    size = paths[1].stat().st_size
    assert main(["cache", "prune", "--cache", str(cache.dir), "--max-size", str(size)]) == 0
    assert "1 left" in capsys.readouterr().out
    assert paths[1].exists() and not paths[2].exists()


def test_cli_prune_bad_arguments(tmp_path, capsys):
    cache, paths = _cache(tmp_path, [40], now=time.time())
    assert main(["cache", "prune", "--cache", str(cache.dir)]) == 2  # bad usage
    err = capsys.readouterr().err
    assert err.startswith("usage: simbridge cache prune ")
    assert err.splitlines()[-1] == (
        "simbridge cache prune: error: give --older-than DAYS or --max-size SIZE (or both): "
        "what to remove"
    )
    assert main(["cache", "prune", "--cache", str(cache.dir), "--max-size", "12Q"]) == 2
    assert "500M" in capsys.readouterr().err
    assert main(["cache", "prune", "--cache", str(cache.dir), "--older-than", "-2"]) == 2
    assert "days >= 0" in capsys.readouterr().err
    assert paths[0].exists()
