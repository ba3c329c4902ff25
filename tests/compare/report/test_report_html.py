"""report.html and its 3D replay (compare/report/html.py, replay.py), and `simbridge replay`.

One short r2d2 comparison (PyBullet against MuJoCo, 0.6 s: the drop, r2d2 leaving the ground on
both engines, ensembles of 2) is reported once per module. The scene's recording is read back
from the page (base64, zstd, msgpack) and checked node by node; a headless Chromium, where one
is installed, loads the page from disk and looks at it."""

from __future__ import annotations

import base64
import html
import io
import itertools
import json
import math
import os
import re
import signal
import subprocess
import sys
import time
import zlib
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from simbridge.compare import compare, report
from simbridge.compare.report import replay as rp

pytest.importorskip("viser", reason="the replay needs viser (simbridge[report])")

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
from _chromium import Browser, chromium  # noqa: E402

MB = 1_000_000


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    c = compare("r2d2", ["pybullet", "mujoco"], duration=0.6, ensemble=2, resync_every=0, workers=0)
    report(c, out, plots=False)
    return c, out


def _recording(page: str) -> dict:
    """The recorded scene inside report.html's viewer: {durationSeconds, messages, ...}."""
    import msgspec
    import zstandard

    srcdoc = re.search(r'<iframe id="replay"[^>]* srcdoc="([^"]*)"', page)
    assert srcdoc is not None, "no replay iframe"
    viewer = html.unescape(srcdoc.group(1))
    data = re.search(r'__VISER_EMBED_DATA__="([^"]+)"', viewer)
    assert data is not None, "no recording in the viewer"
    raw = base64.b64decode(data.group(1))
    inner = zstandard.ZstdDecompressor().decompress(raw[8:], max_output_size=1 << 30)
    n = int.from_bytes(inner[:8], "little")
    return msgspec.msgpack.decode(inner[8 : 8 + n])


def _names(rec: dict, kind: str) -> list[str]:
    return [m["name"] for _, m in rec["messages"] if m.get("type") == kind and "name" in m]


def test_page_is_one_offline_file(written):
    c, out = written
    page = (out / "report.html").read_text(encoding="utf-8")
    assert page.startswith("<!doctype html>")
    # nothing fetched from elsewhere: no script, style or image from a URL
    assert not re.search(r'<(script|img|link|iframe)[^>]+(src|href)="(https?:)?//', page)
    assert "<h1>r2d2: pybullet against mujoco</h1>" in page
    assert "<table>" in page  # report.md's tables
    assert (out / "report.html").stat().st_size < 5 * MB


def _at(page: str, marker: str) -> int:
    at = page.find(marker)
    assert at >= 0, f"{marker!r} not on the page"
    return at


def test_page_opens_on_the_verdicts_then_the_replay_then_folded_prose(written):
    """The title, every pair's verdict in a line, the replay; then report.md's opening
    statements and each of its sections in a <details> whose <summary> is its heading, in
    report.md's order, the opening one unfolded."""
    c, out = written
    page = (out / "report.html").read_text(encoding="utf-8")
    summary = json.loads((out / "summary.json").read_text())
    title, verdicts = _at(page, "<h1>"), _at(page, '<section id="verdicts">')
    replay, prose = _at(page, '<section id="replay-section">'), _at(page, "<details")
    assert title < verdicts < replay < prose
    lines = re.findall(r'<li data-verdict="(\w+)">(.*?)</li>', page[verdicts:replay])
    assert [v for v, _ in lines] == [summary["verdict"]["verdict"]]
    # both engines' legend swatches, then the pair's name and its verdict word with its gap
    blue, orange = rp.ENGINE_COLOURS[:2]
    assert lines[0][1].startswith(
        f'<span class="swatch" style="background:{blue}"></span>'
        f'<span class="swatch" style="background:{orange}"></span><b>pybullet and mujoco</b>: '
    )
    assert f'<span class="word">{summary["verdict"]["verdict"]}' in lines[0][1]
    assert " [" in lines[0][1] and "]" in lines[0][1]  # the judged gap's 95% interval
    # the prose: one fold per section of report.md, with its heading, in its order
    md = (out / "report.md").read_text(encoding="utf-8")
    headings = re.findall(r"^## (.+)$", md, re.M)
    folds = re.findall(
        r'<details class="section"( id="in-words")?( open)?><summary><h2>(.*?)</h2>', page
    )
    assert [html.unescape(re.sub("<[^>]+>", "", h)) for *_, h in folds[1:]] == [
        re.sub(r"`([^`]*)`", r"\1", h) for h in headings
    ]
    assert folds[0][:2] == (' id="in-words"', " open")  # the opening statements, unfolded
    assert all(not o for _, o, _ in folds[1:])  # every section folded
    assert page[prose:].count("</details>") == len(folds)
    assert not re.search(r"<h2[ >]", page[:replay])  # nothing of the prose before the replay


def _mesh_colours(rec: dict, label: str) -> np.ndarray:
    """The colours (0-255 RGB) of every mesh of ``label``'s robots in the recorded scene."""
    return np.array(
        [
            m["props"]["color"]
            for _, m in rec["messages"]
            if m.get("type") == "MeshMessage" and m["name"].startswith(f"/{label}/")
        ],
        dtype=float,
    )


def _hue(rgb: np.ndarray) -> float:
    """Hue in degrees of one RGB colour (any scale)."""
    import colorsys

    r, g, b = (float(x) for x in rgb / max(float(np.max(rgb)), 1e-12))
    return 360.0 * colorsys.rgb_to_hsv(r, g, b)[0]


def _hue_gap(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def _legend_hues(c) -> list[float]:
    return [_hue(rp._rgb(rp.ENGINE_COLOURS[k])) for k in range(len(c.labels))]


def test_each_engines_robot_is_tinted_in_its_legend_colour(written):
    """Every mesh of an engine's robot has its legend colour's hue (the same colours as the
    figures' legend, matplotlib's), whatever the URDF's own colour (r2d2: blue, white, grey),
    only darker for the darker parts."""
    c, out = written
    rec = _recording((out / "report.html").read_text(encoding="utf-8"))
    legend = _legend_hues(c)
    for k, label in enumerate(c.labels):
        colours = _mesh_colours(rec, label)
        assert len(colours) >= 15, label
        for rgb in colours:
            assert _hue_gap(_hue(rgb), legend[k]) < 3.0, (label, rgb)
        # the URDF's light and dark parts stay apart: white parts at the colour, blue darker
        assert np.ptp(colours.max(axis=1)) > 60, (label, colours)
    assert rp._tint((1.0, 1.0, 1.0, 1.0), "#ff7f0e") == (255, 127, 14)


def test_figures_are_inlined(tmp_path):
    c = compare("r2d2", ["pybullet", "mujoco"], duration=0.2, ensemble=1, resync_every=0)
    report(c, tmp_path, replay=False)
    page = (tmp_path / "report.html").read_text(encoding="utf-8")
    pngs = sorted(p.name for p in tmp_path.glob("*.png"))
    assert pngs, "no figure written"
    assert page.count('src="data:image/png;base64,') == len(pngs)
    for name in pngs:
        assert f'src="{name}"' not in page
    # --no-replay: no viewer, no ghosts file; the verdict still opens the page, and with one
    # run per engine it claims no interval
    assert "<iframe" not in page
    top = page[page.index('<section id="verdicts">') : page.index("<details")]
    assert top.count("<li data-verdict=") == 1 and "95% interval" not in top
    assert "a median gap" not in top and "the gap of " in top
    assert not (tmp_path / rp.GHOSTS_FILE).exists()


def test_scene_has_every_engine_its_meshes_and_ghosts(written):
    c, out = written
    rec = _recording((out / "report.html").read_text(encoding="utf-8"))
    meshes = _names(rec, "MeshMessage")
    for label in c.labels:
        mine = [n for n in meshes if n.startswith(f"/{label}/r2d2/")]
        # r2d2.urdf's visuals: every link's box, cylinder, sphere and STL finger
        assert len(mine) >= 15, (label, mine)
        assert f"/{label}/ensemble" in _names(rec, "PointCloudMessage")
    # each engine's links move: poses recorded at every frame, in time order
    times = [t for t, m in rec["messages"] if m.get("type") == "SetPositionMessage"]
    assert times == sorted(times) and times[-1] == pytest.approx(0.6, abs=0.05)
    frames = sorted(set(times))
    assert 10 <= len(frames) <= rp.MAX_FRAMES
    assert rec["durationSeconds"] == pytest.approx(frames[-1])


def test_scene_marks_every_event_at_its_time(written):
    c, out = written
    rec = _recording((out / "report.html").read_text(encoding="utf-8"))
    spheres = {m["name"]: t for t, m in rec["messages"] if m.get("type") == "IcosphereMessage"}
    engines = rp.replay_engines(c)
    marks = rp.event_marks(engines)
    kinds = {m.kind for m in marks}
    assert {"contact_lost", "airborne"} <= kinds, kinds
    for label in c.labels:
        assert any(m.label == label for m in marks), label
    for i, m in enumerate(marks):
        name = f"/events/{m.label}/e{i}_{m.kind}"
        assert name in spheres, name
        # shown from the first frame at or after the event
        assert m.time - 1e-9 <= spheres[name] <= m.time + 1 / rp.FPS + 1e-6
    assert len(spheres) == len(marks)
    page = (out / "report.html").read_text(encoding="utf-8")
    assert page.count('<li><button data-time="') == len(marks)


def test_link_frames_carry_the_recorded_centres_of_mass(written):
    """The replay's link poses (recorded base frame and joints along the URDF) put every
    link's centre of mass where the engine recorded it."""
    from simbridge.model.urdf import parse_urdf, resolve_source

    c, _ = written
    model = parse_urdf(resolve_source("r2d2.urdf"))
    for slot in range(2):
        b = c.runs[(slot, c.timestep)].bodies["r2d2"]
        rows = np.arange(0, len(b.base_position), 7)
        frames = rp.link_poses(model, b, rows)
        for link in model.links:
            pos, rot = frames[link.index]
            com = pos + rot @ np.asarray(link.inertial.origin_xyz)
            k = b.link_names.index("base" if link.index == -1 else link.name)
            np.testing.assert_allclose(com, b.link_positions[rows, k], atol=1e-6)


def test_frames_are_capped():
    class T:
        def __init__(self, n, dt):
            self.time = np.arange(n) * dt
            self.duration = (n - 1) * dt

    rows = rp.frame_rows(T(981, 1 / 240))
    assert rows[0] == 0 and rows[-1] == 980
    assert len(rows) == 124  # 30 per simulated second over 4.08 s
    rows = rp.frame_rows(T(240 * 60 + 1, 1 / 240))  # a minute
    assert len(rows) == rp.MAX_FRAMES and rows[-1] == 240 * 60


def _cpu_s(work: Callable[[], object], tries: int) -> float:
    """The CPU time of ``work()`` in this process, the least of ``tries`` (the least disturbed
    by the rest of the machine)."""
    least = math.inf
    for _ in range(tries):
        started = time.process_time()
        work()
        least = min(least, time.process_time() - started)
    return least


def _unit_of_work() -> None:
    """A fixed piece of work of the replay's kind (numpy on small arrays in a Python loop, the
    bytes compressed): about 0.1 CPU-s here. The replay's cost is counted in it, so that its
    budget means the same on a slow machine as on a fast one."""
    rng = np.random.default_rng(0)
    parts = []
    for _ in range(20_000):
        m = rng.random((4, 3))
        parts.append((m @ m.T).tobytes())
    zlib.compress(b"".join(parts), 6)


REPLAY_BUDGET = 6.0
"""What the replay may add to report(), in units of :func:`_unit_of_work`: measured 0.8 to
1.4 units (0.08 to 0.14 CPU-s here, alone and at load 8); a replay 6 times as costly fails."""


def test_replay_cost(written, monkeypatch):
    """What the replay adds to report(), counted in a fixed unit of work done here, not in
    CPU seconds (it was under 3.0 CPU-s: a figure of one machine's speed). Measured warm, its
    imports done by the module's report (viser's first import, 0.8 CPU-s here in a new
    environment, compiles its files: a cost of the installation that depends on what ran
    before, not of the replay), and made afresh each time, not read from the comparison's
    cache of derived results."""
    from simbridge.compare.report import derived

    c, out = written
    monkeypatch.setattr(derived, "memo", lambda c, kind, parts, make: make())
    k = itertools.count()
    with_replay = _cpu_s(lambda: report(c, out / f"with-{next(k)}", plots=False), 2)
    without = _cpu_s(lambda: report(c, out / f"without-{next(k)}", plots=False, replay=False), 2)
    unit = _cpu_s(_unit_of_work, 3)
    assert with_replay - without < REPLAY_BUDGET * unit, (with_replay, without, unit)


@pytest.fixture(scope="module")
def browser():
    exe = chromium()
    if exe is None:
        pytest.skip("no Chromium here (Debian's chromium; .ci/run installs it as root)")
    with Browser(exe, width=1100, height=1000) as b:
        yield b


def _pixels(png: bytes) -> np.ndarray:
    import matplotlib.image

    return matplotlib.image.imread(io.BytesIO(png), format="png")[..., :3]


def _view(b: Browser) -> np.ndarray:
    r = b.js(
        "(() => { const f = document.getElementById('replay'); f.scrollIntoView();"
        "const c = f.contentDocument.querySelector('canvas').getBoundingClientRect();"
        "const o = f.getBoundingClientRect();"
        "return [o.left + c.left, o.top + c.top, c.width, c.height]; })()"
    )
    x, y, w, h = (int(round(v)) for v in r)
    return _pixels(b.screenshot())[y : y + h, x : x + w]


def _changed(a: np.ndarray, b: np.ndarray) -> float:
    """The share of pixels that differ between two views of the replay."""
    return float((np.abs(a - b).max(axis=2) > 0.1).mean())


def _settled_view(b: Browser, ok: Callable[[np.ndarray], bool], timeout: float = 60) -> np.ndarray:
    """The replay's picture once ``ok`` holds for it and it has stopped changing (two views in a
    row alike): the browser draws when it draws, later on a slow machine (one screenshot after
    a fixed pause of 1.5 to 3.5 s was a bet on its speed). The last view after ``timeout`` s,
    which only bounds a hang."""
    deadline = time.monotonic() + timeout
    last = None
    while True:
        b.pump(0.25)  # the page's events: its console errors are collected
        view = _view(b)
        if ok(view) and last is not None and _changed(last, view) <= 1e-4:
            return view
        if time.monotonic() > deadline:
            return view
        last = view


def test_chromium_draws_the_replay_from_disk(written, browser):
    _, out = written
    b = browser
    b.open(out / "report.html")
    b.wait_for(
        "document.getElementById('replay').contentDocument.querySelector('canvas') !== null"
        " && window.simbridgeSeek(0.05)",
        timeout=120,
    )
    first = _settled_view(b, lambda v: v.std() > 0.02)
    assert first.std() > 0.02, "the 3D canvas is blank"
    assert b.js("window.simbridgeSeek(0.55)")
    later = _settled_view(b, lambda v: _changed(first, v) > 1e-4)
    assert _changed(first, later) > 1e-4, "two scrubber positions give the same picture"
    # hiding both engines changes the picture again
    b.js("document.querySelectorAll('input[data-engine]').forEach(x => x.click())")
    hidden = _settled_view(b, lambda v: _changed(later, v) > 1e-4)
    assert _changed(later, hidden) > 1e-4
    assert b.errors == [], b.errors


def _open_replay(b: Browser, page: Path) -> None:
    """Open ``page`` and wait for the replay's canvas; the viewer's notice that WebGL runs in
    software (headless Chromium's SwiftShader, not a user's GPU) taken off the view."""
    b.open(page)
    b.wait_for(
        "document.getElementById('replay').contentDocument.querySelector('canvas') !== null"
        " && window.simbridgeSeek(0.05)",
        timeout=120,
    )
    b.pump(1.0)
    b.js(
        "(() => { const d = document.getElementById('replay').contentDocument;"
        " for (const e of d.querySelectorAll('[class*=Notification]')) e.remove(); return 1; })()"
    )


def test_chromium_first_screen_is_the_verdicts_and_the_replay(written, browser):
    """At 1280x800, the page as it opens: the verdict lines and the whole replay (its view and
    its playback bar) on the first screen, the prose under it; a section opens on a click of
    its heading, and the buttons fold and open them all."""
    _, out = written
    b = browser
    b.call(
        "Emulation.setDeviceMetricsOverride",
        width=1280,
        height=800,
        deviceScaleFactor=1,
        mobile=False,
    )
    try:
        _open_replay(b, out / "report.html")
        box = json.loads(
            b.js(
                "JSON.stringify({h: window.innerHeight, y: window.scrollY,"
                " verdicts: document.getElementById('verdicts').getBoundingClientRect().bottom,"
                " top: document.getElementById('replay').getBoundingClientRect().top,"
                " bottom: document.getElementById('replay').getBoundingClientRect().bottom,"
                " prose: document.querySelector('details').getBoundingClientRect().top})"
            )
        )
        assert box["h"] == 800 and box["y"] == 0
        assert box["verdicts"] <= box["top"] < box["bottom"] <= box["h"], box
        assert box["prose"] >= box["bottom"], box
        opened = "[...document.querySelectorAll('details.section')].map(d => d.open)"
        assert b.js(opened) == [True] + [False] * (len(b.js(opened)) - 1)
        b.js("document.querySelectorAll('details.section summary')[2].click()")
        assert b.js(opened)[2] is True
        b.js("document.querySelector('button[data-fold=close]').click()")
        assert not any(b.js(opened))
        b.js("document.querySelector('button[data-fold=open]').click()")
        assert all(b.js(opened))
        assert b.errors == [], b.errors
    finally:
        b.call("Emulation.clearDeviceMetricsOverride")


def test_chromium_draws_each_engine_in_its_legend_colour(written, browser):
    """Each engine alone in the view (the others' and the ghosts' boxes unticked): the pixels
    its robot covers, against the view with no engine, have its legend colour's hue."""
    c, out = written
    b = browser
    _open_replay(b, out / "report.html")
    b.js("document.getElementById('ghosts').click()")  # the ensembles' points off
    b.js("window.simbridgeSeek(0.3)")
    boxes = "document.querySelectorAll('input[data-engine]')"
    b.js(f"{boxes}.forEach(x => {{ if (x.checked) x.click(); }})")
    empty = _settled_view(b, lambda v: v.std() > 0.02)
    legend = _legend_hues(c)
    for k, label in enumerate(c.labels):
        b.js(f"{boxes}.forEach((x, i) => {{ if (x.checked !== (i === {k})) x.click(); }})")
        alone = _settled_view(b, lambda v: _changed(empty, v) > 1e-4)
        changed = alone[np.abs(alone - empty).max(axis=2) > 0.1]  # the robot and its shadow
        coloured = changed[np.ptp(changed, axis=1) > 0.15]  # the robot: not the grey shadow
        assert len(coloured) > 200, (label, len(coloured))
        hues = np.array([_hue(x) for x in coloured])
        near = [np.mean([_hue_gap(h, x) < 20.0 for h in hues]) for x in legend]
        assert near[k] > 0.9 and max(near[:k] + near[k + 1 :], default=0.0) < 0.05, (label, near)
    assert b.errors == [], b.errors


def test_cli_no_replay_and_replay_command(written, tmp_path):
    from simbridge.cli import build_parser, main

    args = build_parser().parse_args(["compare", "r2d2", "--no-replay"])
    assert args.no_replay is True
    assert main(["replay", str(tmp_path / "nothing")]) == 1


def test_replay_serves_until_ctrl_c(written):
    _, out = written
    proc = subprocess.Popen(
        [sys.executable, "-m", "simbridge", "replay", str(out), "--port", "8765"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    try:
        line = proc.stdout.readline()  # type: ignore[union-attr]
        url = re.search(r"http://\S+", line)
        assert url is not None, (line, proc.stderr.read() if proc.poll() is not None else "")  # type: ignore[union-attr]
        from urllib.request import urlopen

        page = urlopen(url.group(0), timeout=30).read().decode()
        assert "<html" in page.lower()
        proc.send_signal(signal.SIGINT)
        assert proc.wait(30) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)


def test_engines_from_report_reads_what_report_wrote(written):
    c, out = written
    engines = rp.engines_from_report(out)
    assert [e.label for e in engines] == list(c.labels)
    assert all(e.ghosts is not None and e.ghosts.shape[0] == 1 for e in engines)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["labels"] == list(c.labels)
