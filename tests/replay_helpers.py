"""Shared test helpers for meshcat replays: decode the scene commands embedded in a
``replay.html`` and screenshot pages with headless Chromium.

Chromium (Debian package ``chromium``, /usr/bin/chromium) is required: the CI script
installs it, so a missing browser fails the run instead of skipping it.
"""

from __future__ import annotations

import base64
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest
import umsgpack  # meshcat's msgpack implementation (u-msgpack-python)

CHROMIUM = "/usr/bin/chromium"
_COMMAND = re.compile(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)")


def decode_commands(page: str) -> list[dict]:
    """The scene commands that meshcat's static_html embeds (msgpack, base64)."""
    return [umsgpack.unpackb(base64.b64decode(b)) for b in _COMMAND.findall(page)]


def animation_clips(page: str) -> dict[str, dict]:
    """Scene path → clip of the (single) set_animation command in the page."""
    anims = [c for c in decode_commands(page) if c.get("type") == "set_animation"]
    assert len(anims) == 1, f"expected one set_animation command, found {len(anims)}"
    return {a["path"]: a["clip"] for a in anims[0]["animations"]}


def track(clip: dict, name: str) -> tuple[list, list]:
    """(frames, values) of the track ``.name`` of a clip."""
    (tr,) = [t for t in clip["tracks"] if t["name"] == "." + name]
    return [k["time"] for k in tr["keys"]], [k["value"] for k in tr["keys"]]


#: Put first into the copy of a page that the tests render: ``performance.now`` — which
#: the viewer's animation clock (THREE.Clock) reads — follows Chromium's virtual time, in
#: 10 ms ticks of a ``setInterval`` (timers run on virtual time), instead of the wall clock.
#: ``--virtual-time-budget`` fast-forwards timers but not ``performance.now``: without this
#: the motion's progress when the budget ran out depended on the machine's load (seen in
#: CI: after a 1 s budget the replay stood at 1.7–3.2 s, with 2 busy cores).
_VIRTUAL_CLOCK = """<script>
(function () {
    let now = 0;
    performance.now = function () { return now; };
    setInterval(function () { now += 10; }, 10);
})();
</script>"""


#: Put after :data:`_VIRTUAL_CLOCK` into the copy whose DOM is dumped: animation frames
#: become 16 ms timers, which virtual time cannot pass without running. With compositor
#: frames, virtual time raced through its budget on the 10 ms timers while a loaded CI
#: machine drew few frames: the last frame, and so the clock, stood at 0.17–0.22 s of a
#: 2 s motion after budgets of 4 s and 20 s alike. Screenshots keep compositor frames:
#: with timers the picture taken is not the canvas drawn (both screenshot tests fail).
_FRAMES_ON_TIMERS = """<script>
window.requestAnimationFrame = function (cb) {
    return setTimeout(function () { cb(performance.now()); }, 16);
};
window.cancelAnimationFrame = function (id) { clearTimeout(id); };
</script>"""


def on_virtual_clock(page: Path, out: Path, frames_on_timers: bool = False) -> Path:
    """``out``: a copy of ``page`` whose animation runs on virtual time
    (:data:`_VIRTUAL_CLOCK`, placed first in <head>, and with ``frames_on_timers``
    :data:`_FRAMES_ON_TIMERS`); the page itself is unchanged."""
    text = page.read_text(encoding="utf-8")
    head = text.index("<head>") + len("<head>")
    first = _VIRTUAL_CLOCK + (_FRAMES_ON_TIMERS if frames_on_timers else "")
    out.write_text(text[:head] + first + text[head:], encoding="utf-8")
    return out


def screenshots(
    pages: dict[str, Path], tmp: Path, virtual_time_ms: int = 5000
) -> dict[str, np.ndarray]:
    """Render each page with headless Chromium (in parallel); name → (600, 800, 3) uint8.

    The picture is taken after ``virtual_time_ms`` of the page's virtual time, on which
    the animation plays (:func:`on_virtual_clock`)."""
    from PIL import Image

    if not os.path.exists(CHROMIUM):
        pytest.fail(f"{CHROMIUM} not found: install the Debian package 'chromium' (.ci/run does)")
    procs = {}
    for name, page in pages.items():
        png = tmp / f"{name}.png"
        args = [
            CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu",
            "--disable-background-networking", "--no-first-run", "--disable-component-update",
            "--disable-sync", f"--user-data-dir={tmp / ('profile-' + name)}",
            f"--screenshot={png}", "--window-size=800,600",
            f"--virtual-time-budget={virtual_time_ms}",
            # No host name resolves: the page must render from the file alone.
            "--host-resolver-rules=MAP * ~NOTFOUND",
            on_virtual_clock(page, tmp / f"{name}-virtual-clock.html").resolve().as_uri(),
        ]
        procs[name] = (png, subprocess.Popen(args, stdout=subprocess.PIPE,
                                              stderr=subprocess.STDOUT))
    out = {}
    for name, (png, proc) in procs.items():
        try:
            log, _ = proc.communicate(timeout=90)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()
            pytest.fail(f"chromium timed out on {name}")
        assert proc.returncode == 0 and png.exists(), log.decode(errors="replace")[-2000:]
        out[name] = np.asarray(Image.open(png).convert("RGB"))
    return out


_LEGEND_ROW = re.compile(
    r'<div class="replay-legend" data-node="([^"]*)" data-color="#([0-9a-f]{6})" '
    r'data-kind="([^"]*)"><span[^>]*>[^<]*</span> ([^<]*)'
)


def legend_rows(page: str) -> list[tuple[str, int, str, str]]:
    """(scene node, colour 0xRRGGBB, kind, name) of every legend row of a replay page."""
    import html

    return [(html.unescape(node), int(color, 16), kind, html.unescape(name).strip())
            for node, color, kind, name in _LEGEND_ROW.findall(page)]


def line_points(command: dict) -> np.ndarray:
    """(N, 3) float32 points of a set_object command of a meshcat Line."""
    (geom,) = command["object"]["geometries"]
    arr = geom["data"]["attributes"]["position"]["array"]
    data = arr.data if hasattr(arr, "data") else arr
    return np.frombuffer(data, dtype=np.float32).reshape(-1, 3)


def dump_dom(page: Path, tmp: Path, virtual_time_ms: int) -> str:
    """The DOM of ``page`` after ``virtual_time_ms`` of virtual time in headless Chromium;
    its animation frames run on virtual-time timers (:func:`on_virtual_clock` with
    ``frames_on_timers``), so what the DOM shows depends on virtual time alone."""
    if not os.path.exists(CHROMIUM):
        pytest.fail(f"{CHROMIUM} not found: install the Debian package 'chromium' (.ci/run does)")
    args = [
        CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
        "--disable-background-networking", "--disable-component-update", "--disable-sync",
        f"--user-data-dir={tmp / ('profile-dom-' + page.stem + str(virtual_time_ms))}",
        "--run-all-compositor-stages-before-draw", "--window-size=800,600", "--dump-dom",
        f"--virtual-time-budget={virtual_time_ms}", "--host-resolver-rules=MAP * ~NOTFOUND",
        on_virtual_clock(page, tmp / f"{page.stem}-{virtual_time_ms}-virtual-clock.html",
                         frames_on_timers=True).resolve().as_uri(),
    ]
    proc = subprocess.run(args, capture_output=True, timeout=90)
    assert proc.returncode == 0, proc.stderr.decode(errors="replace")[-2000:]
    return proc.stdout.decode()
