"""What a study's job keys hold besides its arguments, recorded in ``study.json`` as
``inputs`` (:func:`study_inputs`), and what changed since (:func:`inputs_changed`): a report
rebuilt from the cache names what no longer matches."""

from __future__ import annotations

from typing import Any

from ..run.studyjobs import scenario_of

__all__ = ["study_inputs", "inputs_changed"]


def study_inputs(record: dict[str, Any]) -> dict[str, Any]:
    """What a study's job keys hold besides its arguments (``study.json`` records it as
    ``inputs``): the versions of numpy and of its engines' libraries, the digest of
    simbridge's code that makes a run, the hashes of the files its scenario names."""
    from ..run.jobs import engine_versions, file_hashes, run_code_digest

    try:
        files = dict(file_hashes(scenario_of(record)))
    except Exception:  # noqa: BLE001 - a scenario that no longer loads: its runs say why
        files = {}
    return {
        "versions": engine_versions(*record["arguments"]["backends"]),
        "code": run_code_digest(),
        "files": files,
    }


def inputs_changed(then: dict[str, Any], now: dict[str, Any]) -> list[str]:
    """What changed between two :func:`study_inputs`: ``"pybullet 3.2.6 -> 3.2.7"``,
    ``"sapien: not installed -> 3.0.3"``, ``"urdf:robot.urdf changed"``, ``"simbridge's code
    that makes a run changed"``."""
    from ..run.jobs import NOT_INSTALLED

    def shown(version: Any) -> str:
        return "not installed" if version in (None, NOT_INSTALLED) else str(version)

    out = []
    was, is_ = dict(then.get("versions", {})), dict(now.get("versions", {}))
    for dist in dict.fromkeys([*was, *is_]):
        a, b = was.get(dist), is_.get(dist)
        if a != b:
            sep = ": " if NOT_INSTALLED in (a, b) or None in (a, b) else " "
            out.append(f"{dist}{sep}{shown(a)} -> {shown(b)}")
    files_then, files_now = dict(then.get("files", {})), dict(now.get("files", {}))
    for ref in dict.fromkeys([*files_then, *files_now]):
        a, b = files_then.get(ref), files_now.get(ref)
        if a != b:
            what = "not found" if not b else "is new" if a is None else "changed"
            out.append(f"{ref} {what}")
    if then.get("code") != now.get("code"):
        out.append("simbridge's code that makes a run changed")
    return out
