"""The engine settings a study set: summary.json's ``engine_settings`` and report.md's part."""

from __future__ import annotations

from typing import Any

import simbridge
from simbridge.engine_settings import settings_for

__all__ = ["settings_summary", "settings_section"]


def settings_summary(
    scenario: Any, backends: tuple[str, ...] | list[str], profiles: Any, timestep: float
) -> dict[str, dict[str, dict[str, Any]]]:
    """``{backend: {key: {value, default, unit, meaning}}}`` for the settings the study set on
    the backends it ran (empty when it set none)."""
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for slot, backend in enumerate(backends):
        given = scenario.engine(backend)
        if not given or backend in out:
            continue
        known = settings_for(backend)
        prof = simbridge.get_profile(profiles[slot]).with_(timestep=timestep)
        rows = {}
        for key, value in given.items():
            s = known[key]
            default = s.default_for(prof)
            rows[key] = {
                "value": value,
                "default": list(default) if isinstance(default, tuple) else default,
                "unit": s.unit,
                "meaning": s.meaning,
            }
        out[backend] = rows
    return out


def settings_section(s: dict[str, Any]) -> list[str]:
    """report.md's "Engine settings" part: nothing when the study set none."""
    chosen = s.get("engine_settings") or {}
    if not chosen:
        return []
    lines = [
        "## Engine settings",
        "",
        "Set by this study (every run of the engine, ensemble members included); every other "
        "setting keeps the backend's default (`simbridge settings BACKEND` lists them).",
        "",
        "| engine | setting | value | default | meaning |",
        "|---|---|---|---|---|",
    ]
    for backend, rows in chosen.items():
        for key, r in rows.items():
            unit = f" {r['unit']}" if r["unit"] else ""
            lines.append(
                f"| {backend} | `{key}` | {_text(r['value'])}{unit} | {_text(r['default'])}{unit} "
                f"| {r['meaning']} |"
            )
    return [*lines, ""]


def _text(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, list):
        return "[" + ", ".join(_text(x) for x in v) + "]"
    return str(v)
