"""The report stage: ``report.md`` (:mod:`.markdown`), ``summary.json`` (:mod:`.summary_json`), the
figures (:mod:`.plots`), the pictures of the runs (:mod:`.frames`), the terminal's headline
(:mod:`.brief`) and progress bar, from a
:class:`~simbridge.compare.pipeline.Comparison`: :func:`report` writes them all."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ..pipeline import Comparison
from .brief import brief
from .derived import memo_files
from .fmt import file_stem, fmt_distance, fmt_time, fmt_value
from .markdown import headline, markdown
from .resync import plot_resyncs
from .study import write_study
from .summary_json import summary

__all__ = ["report", "headline", "brief", "summary", "fmt_distance", "fmt_time", "fmt_value"]


def report(
    comparison: Comparison,
    out: str | Path,
    *,
    plots: bool = True,
    trajectories: bool = True,
    replay: bool = True,
) -> Path:
    """Write the report of ``comparison`` into folder ``out`` (created if needed).

    Writes ``report.md`` (the file a person opens), ``summary.json`` (every headline figure
    plus the manifests), the PNG figures beside them, and with ``trajectories`` the two
    headline runs as ``trajectories/<engine>.npz`` and ``.csv``; with ``replay`` the pictures
    of the nominal runs (``frames/``: key frames and ``replay.gif``,
    :func:`~simbridge.compare.report.frames.write_frames`). ``report.html`` beside it is the
    same report as one self-contained page (:mod:`.html`), with ``replay`` (and viser,
    ``simbridge[report]``, installed) the 3D replay of every engine's nominal run, whose
    ensembles' ghosts go to ``replay_ghosts.npz`` for ``simbridge replay``. Returns the path of
    ``report.md``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    figures = summary(comparison)
    files = ["summary.json"]
    if trajectories:

        def save() -> tuple[list[str], list[str]]:
            folder = out / "trajectories"
            folder.mkdir(exist_ok=True)
            names = []
            for slot, label in enumerate(comparison.labels):
                tr = comparison.runs[(slot, comparison.timestep)]
                stem = file_stem(label)  # pybullet (2): pybullet-2
                tr.save(folder / f"{stem}.npz")
                tr.save_csv(folder / f"{stem}.csv")
                names += [f"trajectories/{stem}.npz", f"trajectories/{stem}.csv"]
            return names, names

        files += memo_files(comparison, "trajectories", (), out, save)
    images = {}
    if plots:
        names = memo_files(comparison, "figures", (), out, lambda: _plots(comparison, out))
        images = {k: out / v for k, v in names.items()}
    seen: list[str] = []
    if replay:
        from .frames import frames_section, write_frames

        def frames() -> tuple[Any, list[str]]:
            drawn = write_frames(comparison, figures, out)
            return drawn, list(drawn.files)

        drawn = memo_files(comparison, "frames", (), out, frames)
        seen = frames_section(drawn, figures["subject"], comparison.labels)
        files += drawn.files
    figures["files"] = files + [p.name for p in images.values()]
    figures["headline"]["text"] = headline(figures)
    write_study(comparison, out, {"plots": plots, "trajectories": trajectories, "replay": replay})
    (out / "summary.json").write_text(
        json.dumps(figures, indent=2, default=_json_default, allow_nan=True) + "\n",
        encoding="utf-8",
    )
    path = out / "report.md"
    text = markdown(comparison, figures, images, files, seen)
    path.write_text(text, encoding="utf-8")
    from .html import write_html

    _, engines = write_html(comparison, text, out, replay=replay, summary=figures)
    if engines is not None and trajectories:
        from .replay import save_ghosts

        save_ghosts(engines, out)
    return path


def _plots(comparison: Comparison, out: Path) -> tuple[dict[str, str], list[str]]:
    """Draw the PNG figures into ``out``: their names by figure, and the files."""
    from .plots import all_plots

    images = all_plots(comparison, out)
    many = len(comparison.labels) > 2  # each resync figure names its pair
    resyncs = [p.resync for p in comparison.pairs if p.resync is not None]
    if not resyncs and comparison.resync is not None:  # a Comparison made without pairs
        resyncs = [comparison.resync]
    named = [(r, " and ".join(r.labels) if many else None) for r in resyncs]
    images.update(plot_resyncs(named, out))  # resync.png, the first pair's; resync_<a>_<b>.png
    names = {k: Path(p).relative_to(out).as_posix() for k, p in images.items()}
    return names, list(names.values())


def _json_default(obj: Any) -> Any:
    import numpy as np

    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.integer, np.floating, np.bool_)):
        return obj.item()
    return str(obj)
