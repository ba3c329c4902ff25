"""``simbridge sim2sim``'s report.html (:func:`write_html`), through compare's page
(:func:`simbridge.compare.report.html.render_html`).

The page opens on the headline, one line per engine (:func:`headline_html`): its success k/N
with the 95% Wilson interval and, against the training engine, the verdict with McNemar's p
(for a policy trained outside simbridge, no engine being the training engine: each engine's
success, then every pair of engines with its verdict and p).
Then the 3D replay of the chosen seed (:mod:`simbridge.envs.sim2sim_replay`) on every engine in
one scene, each robot tinted in its engine's legend colour, as compare's replay draws a
comparison. Then report.md's figures and sections, each folded as in compare's report.html.
"""

from __future__ import annotations

import html
from pathlib import Path

from simbridge.envs.sim2sim import TRAINED_FLOOR, EngineFigures, Sim2SimResult

__all__ = ["headline_html", "write_html"]


def _line(f: EngineFigures, colour: str, training: str | None) -> str:
    r = f.rate
    rate = f"{r.successes}/{r.n} ({r.low:.2f}-{r.high:.2f}, 95% Wilson)"
    swatch = f'<span class="swatch" style="background:{colour}"></span>'
    if training is None:
        what = "the training engine"
        verdict = "training"
    else:
        what = (
            f'<span class="word">{f.verdict}</span> against {html.escape(training)} '
            f"(McNemar p = {f.p_value:.3g}; lost {f.discordant[0]}, won {f.discordant[1]})"
        )
        verdict = f.verdict
    nan = f", {f.nan_actions} NaN action(s)" if f.nan_actions else ""
    return (
        f'<li data-verdict="{verdict}">{swatch}<b>{html.escape(f.label)}</b>: success '
        f"{rate}, {what}{nan}</li>"
    )


def headline_html(result: Sim2SimResult) -> str:
    """The headline, one line per engine, the training engine's first (for a policy trained
    outside simbridge: one line per engine, then one per pair of engines).

    Args:
        result: the run.

    Returns:
        A ``<section id="headline">`` of one ``<li>`` per engine (``data-verdict``:
        ``training``, ``same``, ``drop`` or ``rise``; ``stated`` for an outside policy, whose
        pairs follow in ``<ul id="pairs">``), each with its legend swatch.
    """
    from simbridge.compare.report.replay import ENGINE_COLOURS
    from simbridge.envs.trained_on import outside

    if outside(result.trained_on) is not None:
        return _external_headline(result)
    training = result.figures[0].label
    rows = "".join(
        _line(f, ENGINE_COLOURS[k % len(ENGINE_COLOURS)], None if k == 0 else training)
        for k, f in enumerate(result.figures)
    )
    contract = ""
    if result.points_at_contract:
        contract = (
            f'<p class="note">The policy succeeds on less than {TRAINED_FLOOR:.0%} of the '
            "seeds on its training engine: look at the contract (joint order, observation "
            "layout and scales, action meaning, gains, dt and decimation) before the engines."
            "</p>"
        )
    return (
        f'<section id="verdicts" class="headline"><ul id="headline">{rows}</ul>{contract}'
        f'<p class="note">{len(result.seeds)} paired episodes per engine; a verdict is '
        "McNemar's exact test on the seeds that succeed on one engine only.</p></section>"
    )


def _external_headline(result: Sim2SimResult) -> str:
    """The headline of a policy trained outside simbridge: each engine's success against the
    stated contract (``data-verdict="stated"``), then every pair of engines by McNemar's exact
    test (:func:`~simbridge.envs.sim2sim_external.pairs`; ``data-verdict`` ``same``, ``drop``
    or ``rise`` of the second against the first)."""
    from simbridge.compare.report.replay import ENGINE_COLOURS
    from simbridge.envs.sim2sim_external import pairs
    from simbridge.envs.trained_on import outside

    name = html.escape(outside(result.trained_on) or "")
    rows = []
    for k, f in enumerate(result.figures):
        r = f.rate
        swatch = (
            f'<span class="swatch" style="background:{ENGINE_COLOURS[k % len(ENGINE_COLOURS)]}">'
            "</span>"
        )
        nan = f", {f.nan_actions} NaN action(s)" if f.nan_actions else ""
        rows.append(
            f'<li data-verdict="stated">{swatch}<b>{html.escape(f.label)}</b>: success '
            f"{r.successes}/{r.n} ({r.low:.2f}-{r.high:.2f}, 95% Wilson), against the contract "
            f"stated for {name}{nan}</li>"
        )
    pair_rows = "".join(
        f'<li data-verdict="{p.verdict}"><b>{html.escape(p.second)}</b> '
        f'<span class="word">{p.verdict}</span> against <b>{html.escape(p.first)}</b> '
        f"(McNemar p = {p.p_value:.3g}; lost {p.lost}, won {p.won})</li>"
        for p in pairs(result)
    )
    contract = ""
    if result.points_at_contract:
        contract = (
            f'<p class="note">The policy succeeds on less than {TRAINED_FLOOR:.0%} of the '
            f"seeds on every engine: look at the contract stated for {name} (joint order, "
            "observation layout and scales, action meaning, gains, dt and decimation) before "
            "the engines.</p>"
        )
    return (
        f'<section id="verdicts" class="headline"><p>Trained outside simbridge ({name}): no '
        "engine is the training engine.</p>"
        f'<ul id="headline">{"".join(rows)}</ul><ul id="pairs">{pair_rows}</ul>{contract}'
        f'<p class="note">{len(result.seeds)} paired episodes per engine; every pair of '
        "engines is judged by McNemar's exact test on the seeds that succeed on one of the two "
        "only.</p></section>"
    )


def _replay_note(result: Sim2SimResult) -> str:
    replay = result.replay
    words = (
        f"The replay: {replay.why}, on every engine in one scene, each robot tinted in its "
        "engine's colour (drag to turn, scroll to zoom); an engine whose episode ended first "
        "holds its last pose."
    )
    off = [f.label for f, same in zip(result.figures, replay.matches, strict=True) if not same]
    if off:
        words += (
            f" Run again for the replay, the episode ended otherwise than in the evaluation on "
            f"{', '.join(off)}."
        )
    return words


def write_html(
    result: Sim2SimResult, markdown_text: str, out: Path, *, replay: bool = True
) -> Path:
    """Write ``out/report.html`` from report.md's text and the figures in ``out``.

    Args:
        result: the run; its ``replay`` (:func:`~simbridge.envs.sim2sim_replay.record_replay`)
            is drawn when set, ``replay`` is true and viser is installed.
        markdown_text: report.md's text.
        out: the report folder (its figures are inlined).
        replay: False: no 3D replay.

    Returns:
        The page's path.
    """
    from simbridge.compare.report import replay as rp
    from simbridge.compare.report.html import render_html
    from simbridge.envs.sim2sim_replay import replay_engines

    engines = viewer = None
    note = ""
    labels = [f.label for f in result.figures]
    if replay and result.replay is not None and rp.available():
        engines = replay_engines(result.replay, labels)
        viewer = rp.replay_html(engines, ghosts=False)
    elif replay and result.replay is not None:
        note = (
            "The 3D replay needs viser: pip install 'simbridge[report]', then `simbridge "
            "replay` on this folder."
        )
    page = render_html(
        markdown_text,
        out,
        title=f"simbridge sim2sim: {result.policy} on {result.task}",
        engines=engines,
        viewer=viewer,
        note=note,
        lead=headline_html(result),
        replay_note=_replay_note(result) if engines else "",
    )
    path = out / "report.html"
    path.write_text(page, encoding="utf-8")
    return path
