"""The checks every table of a scenario file goes through, each error naming the key's path
and its line in the file: :func:`find_key_line` and :class:`TableReader`."""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from typing import Any

from simbridge.exceptions import did_you_mean

from ..errors import ScenarioError
from .model import JointRef

# ---------------------------------------------------------------- finding a key's line


_HEADER = re.compile(r"^\s*(\[\[?)\s*([^\]]+?)\s*\]\]?\s*(#.*)?$")
_KEYLINE = re.compile(r"^\s*([A-Za-z0-9_\-\"'. ]+?)\s*=")


def _split_key(key: str) -> list[str]:
    return [part.strip().strip("\"'") for part in key.split(".")]


def find_key_line(text: str, path: Sequence[str | int]) -> int | None:
    """The 1-based line of the key ``path`` (``["phases", 1, "commands", 0, "mode"]``) in TOML
    ``text``, or of its closest enclosing key or table found; None when nothing matches.

    Understands ``[table]``, ``[[array.of.tables]]`` (counting entries) and ``key = value`` lines;
    inside inline tables and arrays it falls back to the line of the enclosing key."""
    target = list(path)
    best_line: int | None = None
    best_len = 0
    header: list[str | int] = []
    counts: dict[tuple[str | int, ...], int] = {}
    depth = 0  # open brackets of a multi-line value
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0] if '"' not in raw and "'" not in raw else raw
        if depth == 0:
            m = _HEADER.match(line)
            if m:
                names = _split_key(m.group(2))
                resolved: list[str | int] = []
                for i, name in enumerate(names):
                    resolved.append(name)
                    is_last = i == len(names) - 1
                    if m.group(1) == "[[" and is_last:
                        key = tuple(resolved)
                        counts[key] = counts.get(key, -1) + 1
                        resolved.append(counts[key])
                    elif tuple(resolved) in counts:  # parent array of tables: its last entry
                        resolved.append(counts[tuple(resolved)])
                header = resolved
                candidate: list[str | int] = list(header)
            else:
                k = _KEYLINE.match(line)
                if not k:
                    depth += line.count("[") - line.count("]")
                    continue
                candidate = [*header, *_split_key(k.group(1))]
                depth += line.count("[") - line.count("]")
                depth += line.count("{") - line.count("}")
            n = 0
            while n < min(len(candidate), len(target)) and candidate[n] == target[n]:
                n += 1
            if n == len(candidate) and n > best_len:
                best_len, best_line = n, lineno
                if n == len(target):
                    return lineno
        else:
            depth += line.count("[") - line.count("]")
            depth += line.count("{") - line.count("}")
            depth = max(depth, 0)
    return best_line


# ---------------------------------------------------------------- checking values


def _keystr(path: Sequence[str | int]) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else (f".{p}" if out else p)
    return out


PYBULLET_KEYS = {
    "basePosition": "position",
    "base_position": "position",
    "baseOrientation": "orientation",
    "base_orientation": "orientation",
    "useFixedBase": "fixed_base",
    "use_fixed_base": "fixed_base",
    "fileName": "urdf",
    "urdf_path": "urdf",
    "timeStep": "timestep",
    "time_step": "timestep",
    "fixedTimeStep": "timestep",
}
"""The names PyBullet's calls and tutorials give a scenario's keys (``p.loadURDF(fileName,
basePosition, baseOrientation, useFixedBase)``, ``p.setTimeStep(timeStep)``) -> the scenario's."""


def _suggest(key: str, allowed: Sequence[str]) -> str:
    """`` (did you mean 'position'?)`` for an unknown key: PyBullet's name of a key allowed
    here (:data:`PYBULLET_KEYS`, saying so), else the closest allowed key, else ``""``."""
    ours = PYBULLET_KEYS.get(key)
    if ours is not None and ours in allowed:
        return f" (did you mean {ours!r}? the scenario's name for PyBullet's {key})"
    return did_you_mean(key, allowed)


class TableReader:
    """Checks values of one scenario file, raising :class:`ScenarioError` with the key's line.

    Each method takes the key path of the value it checks (``["phases", 1, "steps"]``)."""

    def __init__(self, text: str, file: str):
        self.text = text
        self.file = file

    def error(self, path: Sequence[str | int], detail: str) -> ScenarioError:
        return ScenarioError(self.file, _keystr(path), detail, find_key_line(self.text, path))

    def keys(self, table: dict[str, Any], path: list[str | int], allowed: Sequence[str]) -> None:
        for key in table:
            if key not in allowed:
                raise self.error(
                    [*path, key],
                    f"unknown key{_suggest(str(key), allowed)}; valid keys here: "
                    f"{', '.join(allowed)}",
                )

    def require(self, table: dict[str, Any], path: list[str | int], key: str) -> Any:
        if key not in table:
            where = _keystr(path) or "the top level"
            raise self.error([*path, key], f"missing (required in {where})")
        return table[key]

    def string(self, value: Any, path: list[str | int]) -> str:
        if not isinstance(value, str) or not value:
            raise self.error(path, f"expected a non-empty string, got {value!r}")
        return value

    def number(self, value: Any, path: list[str | int], *, nonneg: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(path, f"expected a number, got {value!r}")
        if not math.isfinite(value):
            raise self.error(path, f"expected a finite number, got {value!r}")
        if nonneg and value < 0:
            raise self.error(path, f"must be >= 0, got {value!r}")
        return float(value)

    def vector(self, value: Any, path: list[str | int], n: int) -> tuple[float, ...]:
        if not isinstance(value, list) or len(value) != n:
            raise self.error(path, f"expected a list of {n} numbers, got {value!r}")
        return tuple(self.number(v, [*path, i]) for i, v in enumerate(value))

    def per_joint(
        self, value: Any, path: list[str | int], n: int, *, nonneg: bool = False
    ) -> tuple[float, ...]:
        if isinstance(value, list):
            if len(value) != n:
                raise self.error(
                    path, f"expected one number or {n} (one per joint), got {len(value)}"
                )
            return tuple(self.number(v, [*path, i], nonneg=nonneg) for i, v in enumerate(value))
        return (self.number(value, path, nonneg=nonneg),) * n

    def joint_ref(self, value: Any, path: list[str | int]) -> JointRef:
        if isinstance(value, bool) or not isinstance(value, (int, str)):
            raise self.error(path, f"expected a joint index or name, got {value!r}")
        if isinstance(value, int) and value < 0:
            raise self.error(path, f"joint indices are >= 0, got {value}")
        return value
