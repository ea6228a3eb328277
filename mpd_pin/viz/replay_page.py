"""The HTML around a meshcat replay (docs/design.md §7c: ``replay.html``).

* :func:`sequence_commands` — apply meshcat's embedded scene commands one after the other,
  the animation last (meshcat's own page starts them all at once, in no set order);
* :func:`decorate` — the page title, a caption with the legend of the end-effector traces and
  markers (meshcat draws no text, so the legend is HTML over the 3-D view, each row naming its
  scene node and colour: ``data-node``, ``data-color``), and a clock: the elapsed time (s) of
  the motion, read from the viewer's animator on every animation frame while it plays.
"""

from __future__ import annotations

import base64
import html
import re
import warnings
from collections.abc import Sequence
from typing import NamedTuple

__all__ = ["LegendRow", "sequence_commands", "decorate", "CLOCK_ID", "LEGEND_CLASS"]

#: ``id`` of the clock element; class of the legend rows.
CLOCK_ID = "replay-clock"
LEGEND_CLASS = "replay-legend"


class LegendRow(NamedTuple):
    """One legend row: ``name``, colour 0xRRGGBB, scene node (below ``/meshcat``), and
    ``kind`` — ``"line"`` (a trace drawn whole), ``"growing line"`` (a trace that grows with
    the motion) or ``"marker"`` (a sphere)."""

    name: str
    color: int
    node: str
    kind: str


# How meshcat 0.3.2's static_html embeds one scene command (zmqserver.create_command).
_FETCH_COMMAND = re.compile(
    r'fetch\("(data:application/octet-binary;base64,[A-Za-z0-9+/=]*)"\)\s*'
    r"\.then\(res => res\.arrayBuffer\(\)\)\s*"
    r"\.then\(buffer => viewer\.handle_command_bytearray\(new Uint8Array\(buffer\)\)\);\s*"
)
_SEQUENTIAL_LOADER = """
(function () {{
    const commands = [
{urls}
    ];
    for (const url of commands) {{
        const text = atob(url.slice(url.indexOf(",") + 1));
        const bytes = new Uint8Array(text.length);
        for (let i = 0; i < text.length; i++) bytes[i] = text.charCodeAt(i);
        viewer.handle_command_bytearray(bytes);
    }}
}})();
"""

# The clock: meshcat's Animator keeps the clip time (s) of its actions in ``time`` while it
# plays (and while the time slider is dragged); t0 is the time of the first sample.
_CLOCK_SCRIPT = """<script>
(function () {{
    const el = document.getElementById("{clock_id}");
    const t0 = {t0!r}, t1 = {t1!r};
    function tick() {{
        const a = (typeof viewer !== "undefined") ? viewer.animator : null;
        const t = t0 + (a && isFinite(a.time) ? Math.min(Math.max(a.time, 0), t1 - t0) : 0);
        el.textContent = "t = " + t.toFixed(2) + " s / " + t1.toFixed(2) + " s";
        el.dataset.time = t.toFixed(6);
        requestAnimationFrame(tick);
    }}
    requestAnimationFrame(tick);
}})();
</script>
"""


def sequence_commands(page: str) -> str:
    """Run the page's scene commands one after the other, the animation last.

    meshcat's static page starts one independent ``fetch`` per command, and they
    complete in no guaranteed order: with large meshes (the Panda's are ~10 MB) a
    static pose could land after the animation had played and undo its last frame,
    and the motion would play while the meshes are still loading. Here the page's
    script decodes every command (base64) and applies them in turn, in one task, so the
    animation starts once the scene is built; with no fetch pending, a headless
    browser's virtual time cannot run ahead of the loading either.
    If the page does not have the expected form it is returned unchanged (with a warning).
    """
    matches = list(_FETCH_COMMAND.finditer(page))
    if not matches or page.count("viewer.handle_command_bytearray") != len(matches):
        warnings.warn("replay: unexpected meshcat page layout; scene commands left as they are",
                      RuntimeWarning, stacklevel=3)
        return page
    first, rest = [], []
    for m in matches:
        head = base64.b64decode(m.group(1).split(",", 1)[1][:64])  # msgpack: "type" comes first
        (rest if b"set_animation" in head else first).append(m.group(1))
    urls = ",\n".join(f'        "{u}"' for u in first + rest)
    start, end = matches[0].start(), matches[-1].end()
    if page[start:end].count("fetch(") != len(matches):
        warnings.warn("replay: unexpected meshcat page layout; scene commands left as they are",
                      RuntimeWarning, stacklevel=3)
        return page
    return page[:start] + _SEQUENTIAL_LOADER.format(urls=urls) + page[end:]


def _legend_html(legend: Sequence[LegendRow]) -> str:
    rows = []
    for row in legend:
        symbol = "&#9679;" if row.kind == "marker" else "&#9472;&#9472;"
        rows.append(
            f'<div class="{LEGEND_CLASS}" data-node="/meshcat/{html.escape(row.node)}" '
            f'data-color="#{row.color:06x}" data-kind="{row.kind}">'
            f'<span style="color:#{row.color:06x}">{symbol}</span> {html.escape(row.name)}'
            + (" <i>(grows with the motion)</i>" if row.kind == "growing line" else "")
            + "</div>"
        )
    return "".join(rows)


def decorate(
    page: str,
    title: str,
    legend: Sequence[LegendRow] = (),
    clock: tuple[float, float] | None = None,
) -> str:
    """``title`` in the page's <title>; a caption (top left) with the title, the clock (with
    ``clock`` = (t0, t1), the times in s of the first and last sample) and the ``legend``."""
    esc = html.escape(title)
    if title:
        page = page.replace("<title>MeshCat</title>", f"<title>{esc}</title>", 1)
    if not title and not legend and clock is None:
        return page
    clock_div = ""
    if clock is not None:
        t0, t1 = (float(x) for x in clock)
        clock_div = (f'<div id="{CLOCK_ID}" data-time="{t0:.6f}" style="font:14px monospace">'
                     f"t = {t0:.2f} s / {t1:.2f} s</div>")
    caption = (
        '<div id="replay-caption" style="position:absolute;left:10px;top:8px;color:#fff;'
        f'font:15px sans-serif;text-shadow:0 0 3px #000;pointer-events:none">'
        f'<div id="replay-title">{esc}</div>{clock_div}'
        f'<div style="font-size:12px">{_legend_html(legend)}</div></div>'
    )
    page = page.replace("<body>", "<body>" + caption, 1)
    if clock is not None:
        script = _CLOCK_SCRIPT.format(clock_id=CLOCK_ID, t0=t0, t1=t1)
        i = page.rfind("</body>")
        page = page[:i] + script + page[i:] if i >= 0 else page + script
    return page
