"""The meshcat replay: scene commands decoded from the HTML, a headless-Chromium render,
server clean-up and input checks.

Chromium (Debian package ``chromium``, /usr/bin/chromium) is required: the CI script
installs it, so a missing browser fails the run instead of skipping it.
"""

from __future__ import annotations

import dataclasses
import math
import os
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from replay_helpers import (
    animation_clips,
    decode_commands,
    dump_dom,
    legend_rows,
    line_points,
    screenshots,
    track,
)

import mpd_pin as mp
from mpd_pin.viz import replay as rp
from mpd_pin.viz import replay_page as rp_page
from mpd_pin.world import Box, Cylinder, Hazard, Polygon, Sphere, World

T_END = 2.0  # s, duration of the planar motion
N_PLANAR = 201  # samples at 100 Hz: closer than 1/fps, so the frame rate is raised to 100
T_REVEAL = 1.0  # s, the hidden obstacle appears halfway


# --------------------------------------------------------------------- helpers
def meshcat_descendants() -> set[int]:
    """PIDs of processes below this one whose command line mentions meshcat."""
    try:
        import psutil
    except ImportError:
        psutil = None
    if psutil is not None:
        out = set()
        for p in psutil.Process().children(recursive=True):
            try:
                if "meshcat" in " ".join(p.cmdline()) and p.status() != psutil.STATUS_ZOMBIE:
                    out.add(p.pid)
            except (psutil.NoSuchProcess, psutil.AccessDenied):
                pass
        return out
    parent, cmd = {}, {}
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text()
            parent[int(d.name)] = int(stat.rsplit(")", 1)[1].split()[1])
            cmd[int(d.name)] = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode()
        except (OSError, ValueError, IndexError):
            continue
    me, out = os.getpid(), set()
    for pid in parent:
        p = pid
        while p in parent and p not in (0, 1, me):
            p = parent[p]
        if p == me and pid != me and "meshcat" in cmd.get(pid, ""):
            out.add(pid)
    return out


def alive(pid: int) -> bool:
    """True if ``pid`` exists and is not a zombie."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.fixture
def server_pids(monkeypatch):
    """Record the PID of every meshcat server that meshcat.Visualizer() starts."""
    import meshcat.visualizer as mv

    pids: list[int] = []
    start = mv.start_zmq_server_as_subprocess

    def recording(*args, **kwargs):
        proc, zmq_url, web_url = start(*args, **kwargs)
        pids.append(proc.pid)
        return proc, zmq_url, web_url

    monkeypatch.setattr(mv, "start_zmq_server_as_subprocess", recording)
    return pids


# ------------------------------------------------------------------- planar arm
def planar_scene():
    arm = mp.builtin_arm("planar_3link")
    world = World(
        (
            Box.planar((0.75, 0.55), 0.2, 0.3, name="wall"),
            Polygon.planar([(-0.85, 0.3), (-0.5, 0.3), (-0.68, 0.6)], name="tri"),
            Cylinder.planar((0.35, -0.75), 0.12, name="ghost", hidden=True),
        )
    )
    times = np.linspace(0.0, T_END, N_PLANAR)
    s = times / T_END
    s = 10 * s**3 - 15 * s**4 + 6 * s**5
    q0, q1 = np.array([0.2, 0.3, 0.2]), np.array([2.6, -0.4, -0.6])
    Q = q0 + np.outer(s, q1 - q0)
    return arm, world, times, Q


def ee_path(arm, Q) -> np.ndarray:
    fid = arm.model.nframes - 1
    data = arm.model.createData()
    pts = []
    for q in Q:
        pin.framesForwardKinematics(arm.model, data, q)
        pts.append(data.oMf[fid].translation.copy())
    return np.array(pts)


@pytest.fixture(scope="module")
def planar(tmp_path_factory):
    """Replays of the planar arm: with arm + reveal, without arm, without reveal."""
    tmp = tmp_path_factory.mktemp("replay_planar")
    arm, world, times, Q = planar_scene()
    armless = dataclasses.replace(arm, visual_model=pin.GeometryModel())
    reveal = {"ghost": T_REVEAL}
    plan = ee_path(arm, Q[::-1])[::20]  # a second trace, drawn whole: the motion reversed
    paths = {"planned": plan, "end effector": ee_path(arm, Q)}
    pages = {
        "arm": rp.write_replay(arm, world, times, Q, tmp / "replay.html", reveal_times=reveal,
                               paths=paths, grow=["end effector"], title="planar 3-link"),
        "no_arm": rp.write_replay(armless, world, times, Q, tmp / "no_arm.html",
                                  reveal_times=reveal, paths=paths, grow=["end effector"],
                                  title="planar 3-link"),
        "no_reveal": rp.write_replay(arm, world, times, Q, tmp / "no_reveal.html",
                                     paths=paths, grow=["end effector"], title="planar 3-link"),
        "whole": rp.write_replay(arm, world, times, Q, tmp / "whole.html", reveal_times=reveal,
                                 paths=paths, title="planar 3-link"),
    }
    return {"arm": arm, "world": world, "times": times, "Q": Q, "pages": pages, "tmp": tmp}


def test_planar_animation_has_one_keyframe_per_sample(planar):
    arm, times, Q = planar["arm"], planar["times"], planar["Q"]
    page = planar["pages"]["arm"].read_text(encoding="utf-8")
    clips = animation_clips(page)
    fps = {c["fps"] for c in clips.values()}
    assert fps == {100.0}  # 100 Hz samples: fps raised from 30 so that no two samples share one
    expected = np.floor((times - times[0]) * 100.0 + 0.5).astype(int)
    assert np.array_equal(expected, np.arange(N_PLANAR))

    data, gdata = arm.model.createData(), arm.visual_model.createData()
    links = [g.name for g in arm.visual_model.geometryObjects]
    assert len(links) == 3
    for gid, name in enumerate(links):
        clip = clips[f"/meshcat/{rp.ARM_NODE}/visuals/{name}"]
        frames, pos = track(clip, "position")
        qframes, quat = track(clip, "quaternion")
        assert len(frames) == len(qframes) == len(times)  # exactly one keyframe per sample
        assert frames == qframes == expected.tolist()
        for k in (0, N_PLANAR // 3, N_PLANAR - 1):  # keyframe values are oMg of that sample
            pin.forwardKinematics(arm.model, data, Q[k])
            pin.updateGeometryPlacements(arm.model, data, arm.visual_model, gdata)
            M = gdata.oMg[gid]
            np.testing.assert_allclose(pos[k], M.translation, atol=1e-12)
            x, y, z, w = quat[k]
            R = pin.Quaternion(w, x, y, z).toRotationMatrix()
            np.testing.assert_allclose(R, M.rotation, atol=1e-9)


def test_planar_hidden_obstacle_turns_on_at_reveal_time(planar):
    times = planar["times"]
    commands = decode_commands(planar["pages"]["arm"].read_text(encoding="utf-8"))
    clips = animation_clips(planar["pages"]["arm"].read_text(encoding="utf-8"))
    clip = clips[f"/meshcat/{rp.WORLD_NODE}/obstacles/ghost"]
    frames, visible = track(clip, "visible")
    on = round((T_REVEAL - times[0]) * clip["fps"])
    first_on = frames[visible.index(True)]
    assert first_on == on == 100
    assert visible[0] is False
    assert all(v is False for f, v in zip(frames, visible, strict=True) if f < on)
    assert all(v is True for f, v in zip(frames, visible, strict=True) if f >= on)
    # Hidden in the static scene too (before the animation plays) ...
    assert {"type": "set_property", "path": f"/meshcat/{rp.WORLD_NODE}/obstacles/ghost",
            "property": "visible", "value": False} in commands
    # ... while the known obstacles have no visibility track and are drawn.
    assert f"/meshcat/{rp.WORLD_NODE}/obstacles/wall" not in clips
    drawn = {c["path"] for c in commands if c["type"] == "set_object"}
    for name in ("wall", "tri", "ghost"):
        assert f"/meshcat/{rp.WORLD_NODE}/obstacles/{name}/shape" in drawn
    assert f"/meshcat/{rp.PATHS_NODE}/planned" in drawn  # drawn whole
    assert f"/meshcat/{rp.PATHS_NODE}/end effector/000" in drawn  # grows: segments
    # Without a reveal time the hidden obstacle never shows.
    clips = animation_clips(planar["pages"]["no_reveal"].read_text(encoding="utf-8"))
    _, visible = track(clips[f"/meshcat/{rp.WORLD_NODE}/obstacles/ghost"], "visible")
    assert not any(visible)


def test_planar_page_is_self_contained(planar):
    page = planar["pages"]["arm"].read_text(encoding="utf-8")
    # Commands run one after the other, the animation last (after the scene is built).
    assert page.count("viewer.handle_command_bytearray") == 1
    assert [c["type"] for c in decode_commands(page)][-1] == "set_animation"
    assert re.search(r"""(src|href)\s*=\s*["']?\s*(https?:)?//""", page) is None
    assert re.search(r"<script[^>]*\bsrc\s*=", page) is None
    assert "<link" not in page and "@import" not in page
    assert "MeshCat.Viewer" in page  # the viewer is inlined, not fetched
    assert "<title>planar 3-link</title>" in page


def test_planar_screenshot_shows_arm_and_revealed_obstacle(planar):
    shots = screenshots(planar["pages"], planar["tmp"])
    img = shots["arm"].astype(int)
    assert img.shape == (600, 800, 3)
    # Not blank: many colours and real contrast.
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 200
    assert img.std() > 20.0

    # The arm: the pixels that differ from the same replay without the arm's geometry.
    diff = np.abs(img - shots["no_arm"].astype(int)).max(axis=2) > 40
    assert diff.sum() > 1500, f"only {diff.sum()} pixels show the arm"
    arm_px = img[diff]
    grey = (arm_px.max(axis=1) - arm_px.min(axis=1)) < 40  # links are grey (0.6, 0.6, 0.65)
    assert grey.mean() > 0.6

    # The hidden obstacle (orange) is on screen after its reveal (the screenshot is taken at
    # 5 s of virtual time, after the 2 s motion), and never without a reveal time: the two
    # pictures differ by an orange region.
    shown = np.abs(img - shots["no_reveal"].astype(int)).max(axis=2) > 40
    assert shown.sum() > 1500, f"only {shown.sum()} pixels show the revealed obstacle"
    r, g, b = img[shown].T
    orange = (r > 180) & (g > 90) & (g < 190) & (b < 60)
    assert orange.mean() > 0.8

    # At the end the growing trace is complete: the page drawing it whole from the start looks
    # the same, but for the caption's "(grows with the motion)" (top left).
    differ = np.abs(img - shots["whole"].astype(int)).max(axis=2) > 40
    caption = np.zeros_like(differ)
    caption[:130, :400] = True
    assert differ[caption].sum() > 0 and differ[~caption].sum() == 0


def test_planar_legend_names_each_trace_and_marker_with_its_colour(planar):
    arm, Q = planar["arm"], planar["Q"]
    page = planar["pages"]["arm"].read_text(encoding="utf-8")
    objects = {c["path"]: c for c in decode_commands(page) if c["type"] == "set_object"}
    rows = legend_rows(page)
    assert [(name, kind) for _, _, kind, name in rows] == [
        ("planned", "line"), ("end effector", "growing line"),
        ("start (end effector)", "marker"), ("goal (end effector)", "marker")]
    colours = [color for _, color, _, _ in rows]
    assert len(set(colours)) == 4  # distinct colours
    whole, grown, start, goal = (node for node, _, _, _ in rows)
    # The whole trace: one line of that colour with the given points.
    assert objects[whole]["object"]["materials"][0]["color"] == colours[0]
    plan = ee_path(arm, Q[::-1])[::20]
    np.testing.assert_allclose(line_points(objects[whole]), plan, atol=1e-6)
    # The growing trace: segments of that colour that together are the path, in order.
    segs = sorted(p for p in objects if p.startswith(grown + "/"))
    assert len(segs) == 100  # 201 samples in segments of 2 steps
    assert {objects[p]["object"]["materials"][0]["color"] for p in segs} == {colours[1]}
    pts = [line_points(objects[p]) for p in segs]
    joined = np.concatenate([pts[0]] + [p[1:] for p in pts[1:]])
    for a, b in zip(pts, pts[1:], strict=False):
        np.testing.assert_array_equal(a[-1], b[0])  # consecutive segments share an end
    np.testing.assert_allclose(joined, ee_path(arm, Q), atol=1e-6)
    # Markers: spheres of their colours at the end effector's first and last position.
    transforms = {c["path"]: c["matrix"] for c in decode_commands(page)
                  if c["type"] == "set_transform"}
    for node, color, q in ((start, colours[2], Q[0]), (goal, colours[3], Q[-1])):
        assert objects[node]["object"]["geometries"][0]["type"] == "SphereGeometry"
        assert objects[node]["object"]["materials"][0]["color"] == color
        M = np.array(transforms[node]).reshape(4, 4).T  # column-major
        np.testing.assert_allclose(M[:3, 3], ee_path(arm, q[None])[0], atol=1e-12)


def test_planar_trace_grows_with_the_motion(planar):
    times = planar["times"]
    page = planar["pages"]["arm"].read_text(encoding="utf-8")
    clips = animation_clips(page)
    node = f"/meshcat/{rp.path_node('end effector')}"
    bounds = rp.segment_bounds(N_PLANAR)
    assert bounds.tolist() == list(range(0, N_PLANAR, 2))
    frames = np.floor((times - times[0]) * 100.0 + 0.5).astype(int)  # as the keyframe test
    last = int(frames[-1])
    static_hidden = {c["path"] for c in decode_commands(page) if c["type"] == "set_property"
                     and c["property"] == "visible" and c["value"] is False}
    for j, hi in enumerate(bounds[1:]):
        seg = f"{node}/{j:03d}"
        keyframes, visible = track(clips[seg], "visible")
        at = dict(zip(keyframes, visible, strict=True))
        assert at[0] is False and at[last] is True  # t = 0: hidden; end: shown
        on = frames[hi]  # shown from the frame the motion reaches the segment's end
        assert keyframes[visible.index(True)] == on
        assert seg in static_hidden  # hidden before the animation starts too
    # The trace drawn whole has no visibility track.
    assert f"/meshcat/{rp.path_node('planned')}" not in clips


def test_planar_clock_runs_in_the_browser(planar):
    page = planar["pages"]["arm"]
    text = page.read_text(encoding="utf-8")
    assert f'<div id="{rp_page.CLOCK_ID}"' in text and "t = 0.00 s / 2.00 s" in text
    clock = re.compile(r'<div id="replay-clock" data-time="([0-9.]+)"[^>]*>([^<]*)<')
    # The page decodes its scene commands in its own script (with fetches pending, the DOM was
    # dumped before the animation started in about 1 run in 4: clock at 0). The copy rendered
    # runs the animation and its frames on virtual time (replay_helpers.on_virtual_clock):
    # with compositor frames a loaded CI drew too few of them, and the clock stood at
    # 0.17-0.22 s after 4 s and 20 s budgets alike. On timers, a 1 s budget reads 1.00-1.01 s
    # idle and with 4 busy loops on the 2 cores.
    end = clock.search(dump_dom(page, planar["tmp"], 4_000))
    assert end is not None
    assert float(end.group(1)) == pytest.approx(T_END) and end.group(2) == "t = 2.00 s / 2.00 s"
    # With the clock's script disabled the element keeps its initial 0: the value above was
    # written by the script from the playing animation, not by the page generator.
    assert text.count("requestAnimationFrame(tick);") == 2
    frozen = planar["tmp"] / "frozen.html"
    frozen.write_text(text.replace("requestAnimationFrame(tick);", ""), encoding="utf-8")
    still = clock.search(dump_dom(frozen, planar["tmp"], 4_000))
    assert float(still.group(1)) == 0.0 and still.group(2) == "t = 0.00 s / 2.00 s"


def test_grow_checks_its_paths(tmp_path, server_pids):
    arm, world, times, Q = planar_scene()
    with pytest.raises(ValueError, match="not one of the paths"):
        rp.write_replay(arm, world, times[:10], Q[:10], tmp_path / "g.html", grow=["x"])
    with pytest.raises(ValueError, match="one point per sample"):
        rp.write_replay(arm, world, times[:10], Q[:10], tmp_path / "g.html",
                        paths={"x": np.zeros((4, 3))}, grow=["x"])
    assert not server_pids


# ------------------------------------------------------------------------- Panda
def test_panda_with_box(tmp_path, server_pids):
    arm = mp.Arm.from_example_robot_data("panda")
    world = World((Box((0.2, 0.6, 0.4), position=(0.55, 0.0, 0.2), name="box"),
                   Hazard(Sphere(0.1, position=(0.3, 0.4, 0.5), name="zone"), 0.05)))
    n = 90
    times = np.arange(n) / 30.0  # exactly 30 Hz: frame k for sample k at fps 30
    q1 = arm.q_reference + np.array([1.0, -0.3, 0.2, 0.5, 0.3, 0.4, -0.5])
    Q = arm.q_reference + np.outer(np.linspace(0.0, 1.0, n), q1 - arm.q_reference)
    out = rp.write_replay(arm, world, times, Q, tmp_path / "panda.html", title="panda")
    page = out.read_text(encoding="utf-8")
    print(f"panda replay: {out.stat().st_size / 1e6:.1f} MB")
    clips = animation_clips(page)
    names = [g.name for g in arm.visual_model.geometryObjects]
    assert len(names) >= 8
    for name in names:
        clip = clips[f"/meshcat/{rp.ARM_NODE}/visuals/{name}"]
        assert clip["fps"] == 30.0
        frames, _ = track(clip, "position")
        assert frames == list(range(n))
    commands = decode_commands(page)
    meshes = [c for c in commands if c["type"] == "set_object"
              and c["path"].startswith(f"/meshcat/{rp.ARM_NODE}/visuals/")]
    assert len(meshes) == len(names)  # every visual mesh is in the page
    drawn = {c["path"] for c in commands if c["type"] == "set_object"}
    assert {f"/meshcat/{rp.WORLD_NODE}/obstacles/box/shape",
            f"/meshcat/{rp.WORLD_NODE}/hazards/zone/shape"} <= drawn
    assert len(server_pids) == 1 and not alive(server_pids[0])
    assert not meshcat_descendants()


# ---------------------------------------------------------------- server clean-up
def test_no_server_left_after_replay_or_error(tmp_path, server_pids, monkeypatch):
    arm, world, times, Q = planar_scene()
    before = meshcat_descendants()
    rp.write_replay(arm, world, times[:5], Q[:5], tmp_path / "a.html")
    assert len(server_pids) == 1 and not alive(server_pids[0])

    def boom(*args, **kwargs):
        raise RuntimeError("boom")

    monkeypatch.setattr(rp, "_frame_camera", boom)  # fail while the server is running
    with pytest.raises(RuntimeError, match="boom"):
        rp.write_replay(arm, world, times[:5], Q[:5], tmp_path / "b.html")
    assert len(server_pids) == 2 and not alive(server_pids[1])
    assert not (tmp_path / "b.html").exists()
    assert meshcat_descendants() <= before == set()


def test_reveal_before_start_after_end_and_hidden_hazard(tmp_path):
    arm, _, times, Q = planar_scene()
    world = World(
        (
            Sphere.planar((0.9, 0.9), 0.1, name="early", hidden=True),
            Sphere.planar((-0.9, 0.9), 0.1, name="late", hidden=True),
            Sphere.planar((0.9, -0.9), 0.1, name="never", hidden=True),
            Hazard(Sphere.planar((-0.9, -0.9), 0.1, name="hot", hidden=True), 0.05),
        )
    )
    t, q = times[:21], Q[:21]  # 0 … 0.2 s at 100 Hz: frames 0 … 20
    reveal = {"early": -1.0, "late": 5.0, "hot": 0.1}
    page = rp.write_replay(arm, world, t, q, tmp_path / "r.html", reveal_times=reveal).read_text()
    clips = animation_clips(page)

    def keys(name):
        frames, visible = track(clips["/meshcat/" + rp.obstacle_node(world[name])], "visible")
        return list(zip(frames, visible, strict=True))

    assert keys("early") == [(0, True), (20, True)]
    assert keys("late") == [(0, False), (20, False)]  # revealed after the recording
    assert keys("never") == [(0, False), (20, False)]
    assert keys("hot") == [(0, False), (10, True), (20, True)]
    assert rp.obstacle_node(world["hot"]).startswith(f"{rp.WORLD_NODE}/hazards/")
    hidden_static = {c["path"] for c in decode_commands(page)
                     if c["type"] == "set_property" and c["property"] == "visible"
                     and c["value"] is False and "/world/" in c["path"]}
    assert hidden_static == {"/meshcat/" + rp.obstacle_node(world[n])
                             for n in ("late", "never", "hot")}


def test_single_sample_is_a_still(tmp_path):
    arm, world, times, Q = planar_scene()
    page = rp.write_replay(arm, world, times[:1], Q[:1], tmp_path / "still.html").read_text()
    commands = decode_commands(page)
    assert not any(c["type"] == "set_animation" for c in commands)
    assert any(c["type"] == "set_object" and "/visuals/" in c["path"] for c in commands)


# ------------------------------------------------------------------ keyframe map
def test_keyframe_indices():
    t = np.arange(10) / 30.0
    idx, f = rp.keyframe_indices(t, 30.0)
    assert f == 30.0 and idx.tolist() == list(range(10))
    t = 5.0 + np.arange(10) * 0.01  # 100 Hz, offset start: f raised, frames from 0
    idx, f = rp.keyframe_indices(t, 30.0)
    assert f == 100.0 and idx.tolist() == list(range(10))
    rng = np.random.default_rng(0)
    t = np.cumsum(rng.uniform(1e-3, 0.2, 300))
    idx, f = rp.keyframe_indices(t, 30.0)
    assert np.all(np.diff(idx) > 0)
    assert np.max(np.abs(idx / f - (t - t[0]))) <= 0.5 / f + 1e-12
    idx, f = rp.keyframe_indices(np.array([0.0, 1.0, 2.0]), 30.0)  # slow samples: fps kept
    assert f == 30.0 and idx.tolist() == [0, 30, 60]


# -------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    "change, match",
    [
        (lambda t, Q: (t[:-1], Q), "shape"),
        (lambda t, Q: (t, Q[:, :2]), "arm.nq"),
        (lambda t, Q: (t, Q[0]), "shape"),
        (lambda t, Q: (t[::-1], Q), "strictly increasing"),
        (lambda t, Q: (np.r_[t[:3], t[2], t[4:]], Q), "strictly increasing"),
        (lambda t, Q: (np.r_[np.nan, t[1:]], Q), "NaN"),
        (lambda t, Q: (t, np.where(np.arange(len(t))[:, None] == 3, np.nan, Q)), "NaN"),
        (lambda t, Q: (np.array([]), Q[:0]), "non-empty"),
    ],
)
def test_bad_input_raises_value_error(tmp_path, server_pids, change, match):
    arm, world, times, Q = planar_scene()
    t, q = change(times[:10], Q[:10])
    with pytest.raises(ValueError, match=match):
        rp.write_replay(arm, world, t, q, tmp_path / "bad.html")
    assert not server_pids and not (tmp_path / "bad.html").exists()


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"fps": 0.0}, "fps"),
        ({"fps": math.inf}, "fps"),
        ({"reveal_times": {"nope": 1.0}}, "unknown obstacle"),
        ({"reveal_times": {"wall": 1.0}}, "not a hidden"),
        ({"reveal_times": {"ghost": math.nan}}, "finite"),
        ({"paths": {"ee": np.zeros((5, 2))}}, r"\(N, 3\)"),
        ({"paths": {"ee": np.full((5, 3), np.nan)}}, "NaN"),
    ],
)
def test_bad_options_raise_value_error(tmp_path, server_pids, kwargs, match):
    arm, world, times, Q = planar_scene()
    with pytest.raises(ValueError, match=match):
        rp.write_replay(arm, world, times[:10], Q[:10], tmp_path / "bad.html", **kwargs)
    assert not server_pids


def test_world_must_be_a_world(tmp_path):
    arm, _, times, Q = planar_scene()
    with pytest.raises(ValueError, match="World"):
        rp.write_replay(arm, [Box((1, 1, 1))], times[:3], Q[:3], tmp_path / "bad.html")

