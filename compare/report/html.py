"""``report.html``: the report as one self-contained page that opens from disk, offline.

It opens on the picture: the title, every pair's verdict in a line (:mod:`.html_top`), then the
3D replay (:mod:`.replay`): viser's viewer with the recorded scene in an ``<iframe srcdoc>``
sized to fit the first screen, the engines' colours with a checkbox each (to hide or show an
engine, its ensemble's ghosts and its event markers), a checkbox for the ghosts, and the events
as a clickable timeline and list that move the viewer's time scrubber there. The prose follows:
report.md's text and tables (rendered by markdown-it-py, the figures inlined as ``data:``
URIs), its opening statements unfolded and each ``##`` section a ``<details>`` to open.
"""

from __future__ import annotations

import base64
import html
import re
from pathlib import Path
from typing import Any

__all__ = ["render_html", "write_html"]

_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", sans-serif; margin: 0 auto;
  max-width: 1100px; padding: 1em 1.5em 4em; color: #222; line-height: 1.45; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.92em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.55em; text-align: left; }
th { background: #f3f3f3; }
img { max-width: 100%; }
code { background: #f4f4f4; padding: 0 0.2em; border-radius: 3px; }
pre { background: #f4f4f4; padding: 0.7em; overflow-x: auto; }
h1 { font-size: 1.6em; margin: 0.2em 0 0.3em; }
#verdicts ul { margin: 0.2em 0; padding-left: 1.2em; }
#verdicts li { margin: 0.1em 0; }
#verdicts .word { font-weight: 600; }
#verdicts .note { margin: 0.2em 0 0.4em; }
#replay-section { border: 1px solid #ddd; border-radius: 6px; padding: 0.4em 0.8em;
  margin: 0.4em 0 1em; background: #fafafa; }
#replay-section h2 { font-size: 1.1em; margin: 0 1em 0 0; display: inline; }
#replay { width: 100%; height: max(340px, calc(100vh - 260px)); border: 1px solid #ccc;
  background: #fff; display: block; margin-top: 0.3em; }
details.section { border-top: 1px solid #ddd; padding: 0.1em 0; }
details.section > summary { cursor: pointer; padding: 0.2em 0; }
details.section > summary h2 { display: inline; font-size: 1.25em; margin: 0; }
details.section[open] > summary { margin-bottom: 0.4em; }
.folds { margin: 0.6em 0 0.2em; }
.folds button { font-size: 0.85em; cursor: pointer; }
.engines label { margin-right: 1.2em; white-space: nowrap; }
.swatch { display: inline-block; width: 0.9em; height: 0.9em; border-radius: 2px;
  vertical-align: -0.1em; margin-right: 0.3em; }
#timeline { position: relative; height: 22px; background: #eee; border-radius: 3px;
  margin: 0.6em 0 0.3em; }
#timeline .tick { position: absolute; top: 2px; width: 4px; height: 18px; margin-left: -2px;
  cursor: pointer; border-radius: 1px; opacity: 0.85; }
#timeline .tick:hover { opacity: 1; outline: 1px solid #000; }
#events { max-height: 16em; overflow-y: auto; font-size: 0.9em; margin: 0; }
#events button { font-family: monospace; cursor: pointer; margin-right: 0.4em; }
.note { color: #666; font-size: 0.9em; }
"""

_JS = """
(function () {
  const frame = document.getElementById('replay');
  const hidden = new Set();
  let noGhosts = false;
  function timeInput() {
    const d = frame.contentDocument;
    if (!d) return null;
    return [...d.querySelectorAll('input')].find(i => /^-?[0-9.]+$/.test(i.value)) || null;
  }
  // Move the viewer's time scrubber to t seconds (the viewer pauses there).
  window.simbridgeSeek = function (t) {
    const inp = timeInput();
    if (!inp) return false;
    const setter = Object.getOwnPropertyDescriptor(
      frame.contentWindow.HTMLInputElement.prototype, 'value').set;
    setter.call(inp, String(t));
    inp.dispatchEvent(new frame.contentWindow.Event('input', {bubbles: true}));
    return true;
  };
  function engineOf(name) {
    const parts = name.split('/');
    return parts[1] === 'events' ? parts[2] : parts[1];
  }
  // An engine hidden: its objects leave every camera layer (the viewer redraws them each
  // frame, so this is kept up on every animation frame).
  function apply() {
    const w = frame.contentWindow;
    const m = w && w.__viserMutable;
    if (m && m.nodeRefFromName) {
      let changed = false;
      for (const [name, obj] of Object.entries(m.nodeRefFromName)) {
        if (!obj || !obj.traverse) continue;
        const off = hidden.has(engineOf(name)) || (noGhosts && name.endsWith('/ensemble'));
        obj.traverse(o => {
          if (o.userData.simbridgeMask === undefined) o.userData.simbridgeMask = o.layers.mask;
          const want = off ? 0 : o.userData.simbridgeMask;
          if (o.layers.mask !== want) { o.layers.mask = want; changed = true; }
        });
      }
      if (changed && m.requestRender) m.requestRender();
    }
    requestAnimationFrame(apply);
  }
  requestAnimationFrame(apply);
  for (const box of document.querySelectorAll('input[data-engine]')) {
    box.addEventListener('change', () => {
      if (box.checked) hidden.delete(box.dataset.engine); else hidden.add(box.dataset.engine);
    });
  }
  const ghosts = document.getElementById('ghosts');
  if (ghosts) ghosts.addEventListener('change', () => { noGhosts = !ghosts.checked; });
  for (const el of document.querySelectorAll('[data-time]')) {
    el.addEventListener('click', () => window.simbridgeSeek(parseFloat(el.dataset.time)));
  }
})();
"""


_FOLD_JS = """
for (const b of document.querySelectorAll('button[data-fold]')) {
  b.addEventListener('click', () => {
    const open = b.dataset.fold === 'open';
    for (const d of document.querySelectorAll('details.section')) d.open = open;
  });
}
"""


def _data_uri(path: Path) -> str:
    kind = {".png": "image/png", ".gif": "image/gif", ".jpg": "image/jpeg", ".svg": "image/svg+xml"}
    mime = kind.get(path.suffix.lower(), "application/octet-stream")
    return f"data:{mime};base64," + base64.b64encode(path.read_bytes()).decode("ascii")


def _markdown_html(text: str, folder: Path) -> str:
    from markdown_it import MarkdownIt

    body = MarkdownIt("commonmark", {"html": False}).enable("table").render(text)

    def inline(m: re.Match[str]) -> str:
        src = html.unescape(m.group(1))
        path = (folder / src).resolve()
        inside = path.is_relative_to(folder.resolve()) and ":" not in src
        if inside and path.is_file():  # the report's own figures and frames
            return f'src="{_data_uri(path)}"'
        return m.group(0)

    return re.sub(r'src="([^"]+)"', inline, body)


REPLAY_NOTE = (
    "Every engine's recorded nominal run in one scene, each robot tinted in its engine's colour "
    "(drag to turn, scroll to zoom)."
)
"""What the replay shows, the first words under it (``render_html(replay_note=...)``)."""


def _replay_section(
    engines: list[Any], viewer: str, duration: float, note: str = REPLAY_NOTE
) -> str:
    from .replay import _name, event_marks

    marks = event_marks(engines)
    boxes = "".join(
        f'<label><input type="checkbox" checked data-engine="{_name(e.label)}">'
        f'<span class="swatch" style="background:{e.colour}"></span>{html.escape(e.label)}'
        "</label>"
        for e in engines
    )
    if any(e.ghosts is not None for e in engines):
        boxes += (
            '<label><input type="checkbox" id="ghosts" checked>'
            "ensemble members (faint points)</label>"
        )
    ticks = []
    rows = []
    span = duration if duration > 0 else 1.0
    for m in marks:
        colour = engines[m.engine].colour
        ticks.append(
            f'<div class="tick" data-time="{m.time:.6g}" title="{html.escape(m.words)}, '
            f't = {m.time:.3f} s" style="left:{100 * m.time / span:.3f}%;'
            f'background:{colour}"></div>'
        )
        rows.append(
            f'<li><button data-time="{m.time:.6g}">{m.time:7.3f} s</button>'
            f'<span class="swatch" style="background:{colour}"></span>'
            f"{html.escape(m.words)}</li>"
        )
    events = (
        f'<div id="timeline" title="events: click to jump there">{"".join(ticks)}</div>'
        f'<ul id="events">{"".join(rows)}</ul>'
        if marks
        else '<p class="note">No contact, airborne, tip-over or joint-limit event.</p>'
    )
    return (
        '<section id="replay-section"><h2>Replay</h2>'
        f'<span class="engines">{boxes}</span>'
        f'<iframe id="replay" title="3D replay" srcdoc="{html.escape(viewer, quote=True)}">'
        "</iframe>"
        f'<p class="note">{html.escape(note, quote=False)} Under the view: play and pause, '
        "the time scrubber and the speed; the tree icon lists the scene's nodes. Spheres mark "
        "the events below from the instant they happen; click an event to move the scrubber "
        f"there.</p>{events}</section>"
    )


def render_html(
    markdown_text: str,
    folder: Path,
    *,
    title: str,
    engines: list[Any] | None = None,
    viewer: str | None = None,
    note: str = "",
    summary: dict[str, Any] | None = None,
    lead: str = "",
    replay_note: str = REPLAY_NOTE,
) -> str:
    """The page, in the order a reader wants it: report.md's title; with ``summary`` the
    verdict of every pair in a line each (:func:`~.html_top.verdict_lines_html`); ``lead``
    (another command's headline, as HTML: ``simbridge sim2sim``'s); with
    ``viewer`` (:func:`~.replay.replay_html`) and ``engines`` the replay section (else ``note``
    there, if any); then report.md's opening statements and its sections, each a ``<details>``
    to fold (:func:`~.html_top.fold_sections`), with the figures of ``folder`` inlined.

    Args:
        markdown_text: report.md's text.
        folder: the report folder, whose figures are inlined.
        title: the page's ``<title>``.
        engines: the replay's engines (:class:`~.replay.ReplayEngine`), for its legend.
        viewer: the replay's viewer document; None: no replay.
        note: said where the replay would be, when there is none.
        summary: ``summary.json``'s dict; None: no verdict lines.
        lead: HTML put after the verdict lines, before the replay.
        replay_note: what the replay shows, in words, under it.

    Returns:
        The page's HTML.
    """
    from .html_top import fold_sections, verdict_lines_html
    from .replay import ENGINE_COLOURS

    head, opening, sections = fold_sections(_markdown_html(markdown_text, folder))
    top = ""
    if summary is not None:
        labels = summary["labels"]
        colours = {x: ENGINE_COLOURS[k % len(ENGINE_COLOURS)] for k, x in enumerate(labels)}
        top = verdict_lines_html(summary, colours)
    top += lead
    script = ""
    if viewer is not None and engines:
        tr = engines[0].trajectory
        top += _replay_section(engines, viewer, float(tr.time[-1] - tr.time[0]), replay_note)
        script = f"<script>{_JS}</script>"
    elif note:
        top += f'<p class="note">{html.escape(note)}</p>'
    if opening.strip():
        opening = (
            '<details class="section" id="in-words" open><summary><h2>The verdict in words'
            f"</h2></summary>\n{opening}</details>\n"
        )
    folds = (
        '<p class="folds"><button type="button" data-fold="open">Open every section</button> '
        '<button type="button" data-fold="close">Fold every section</button></p>'
    )
    return (
        '<!doctype html>\n<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{html.escape(title)}</title><style>{_CSS}</style></head>"
        f"<body>{head}{top}{folds}{opening}{sections}"
        f"<script>{_FOLD_JS}</script>{script}</body></html>\n"
    )


def write_html(
    comparison: Any,
    markdown_text: str,
    out: Path,
    *,
    replay: bool = True,
    summary: dict[str, Any] | None = None,
) -> tuple[Path, list[Any] | None]:
    """Write ``out/report.html`` from report.md's text and the figures in ``out``; with
    ``replay`` (and viser installed) the 3D replay too, and with ``summary`` (``summary.json``'s
    dict) every pair's verdict over it. Returns its path and the replay's engines (None without
    a replay)."""
    from . import replay as rp

    engines = viewer = None
    note = ""
    if replay and rp.available():
        from .derived import memo

        engines = rp.replay_engines(comparison)
        viewer = memo(comparison, "replays", (), lambda: rp.replay_html(engines))
    elif replay:
        note = (
            "The 3D replay needs viser: pip install 'simbridge[report]', then "
            "`simbridge replay` on this folder, or run the comparison again."
        )
    title = f"simbridge: {comparison.scenario.name}"
    page = render_html(
        markdown_text, out, title=title, engines=engines, viewer=viewer, note=note, summary=summary
    )
    path = out / "report.html"
    path.write_text(page, encoding="utf-8")
    return path, engines
