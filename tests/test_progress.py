"""Progress on long runs (issues 23 and 34): every long phase shows a bar or a status line
on stderr, and nothing is written there when progress is off. On a terminal the bars are
tqdm frames, also on a pty that reports no window size; elsewhere (a pipe, a file, pytest's
capture) one line per bar and no ``\r``.

References: one unchunked ``edges_free`` call for the chunked edge checks (same mask, same
certification counts); stderr as captured by pytest (``capfd``), a real pty (``pty``
module) and a pipe for the bars; the candidate pairs of the roadmap for their totals."""

from __future__ import annotations

import dataclasses
import fcntl
import io
import os
import pty
import re
import select
import struct
import subprocess
import sys
import termios
import time

import numpy as np
import pytest

import mpd_pin as mp
import mpd_pin.planning.roadmap as rmod
from mpd_pin.app.kinds import load_scenario
from mpd_pin.app.plan import plan_path, prepare
from mpd_pin.collision import CollisionChecker
from mpd_pin.motion.refine import MotionOptions, refine_candidates
from mpd_pin.progress import bar, status
from mpd_pin.world import Box, World

try:
    from test_collision import SLIDER_URDF
except ImportError:  # pragma: no cover
    from tests.test_collision import SLIDER_URDF


class _RecordingBar:
    """A stand-in bar that records what it was made with and how far it got."""

    made: list[_RecordingBar] = []

    def __init__(self, *args, total=None, desc=None, **kw):
        self.total, self.desc, self.n, self.updates = total, desc, 0, []
        _RecordingBar.made.append(self)

    def update(self, n=1):
        self.n += n
        self.updates.append(self.n)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


@pytest.fixture(scope="module")
def panda_pairs():
    """The panda scenario's checker and its roadmap's candidate edges (sampled nodes, k
    nearest neighbours), before the collision check: (checker, nodes, pairs, Q0, Q1, r)."""
    scn = load_scenario("panda")
    checker = CollisionChecker(scn.arm, scn.world)
    opts = scn.options
    nodes = rmod._sample_nodes(checker, scn.arm, scn.start, scn.goal, opts, rmod._tqdm(False),
                               False)
    pairs = rmod._neighbour_pairs(nodes, opts.k, scn.arm.continuous_mask)
    Q0 = nodes[pairs[:, 0]]
    Q1 = scn.arm.edge_target(Q0, nodes[pairs[:, 1]])
    return checker, nodes, pairs, Q0, Q1, opts.resolution


def test_chunked_edge_checks_equal_one_batch(panda_pairs):
    """edges_free with a progress callback checks the panda roadmap's candidate edges in
    several chunks, reports a growing count that ends at the number of pairs, and gives the
    mask (and the certification counts) of one unchunked call; also in discrete mode."""
    checker, _, pairs, Q0, Q1, r = panda_pairs
    K = len(pairs)
    whole = checker.edges_free(Q0, Q1, r)
    whole_stats = dict(checker.last_certify_stats)
    assert whole.any() and not whole.all()  # both answers occur
    done: list[int] = []
    chunked = checker.edges_free(Q0, Q1, r, progress=done.append)
    np.testing.assert_array_equal(chunked, whole)
    assert len(done) >= 3 and done[-1] == K and np.all(np.diff(done) > 0)
    assert checker.last_certify_stats == whole_stats
    sub = slice(0, 300)  # discrete: per-trajectory early exit, chunks of the same edges
    disc = checker.edges_free(Q0[sub], Q1[sub], r, mode="discrete")
    done = []
    np.testing.assert_array_equal(
        checker.edges_free(Q0[sub], Q1[sub], r, mode="discrete", progress=done.append), disc)
    assert len(done) >= 2 and done[-1] == 300


def test_edge_check_bar_reaches_the_number_of_pairs(panda_pairs):
    """The roadmap's "edge checks" bar has total = number of candidate pairs and reaches it;
    the free pairs are those of the unchunked check."""
    checker, nodes, pairs, Q0, Q1, r = panda_pairs
    _RecordingBar.made.clear()
    free = rmod._free_pairs(checker, nodes, pairs, r, _RecordingBar, True)
    (shown,) = [b for b in _RecordingBar.made if b.desc == "edge checks"]
    assert shown.total == len(pairs) and shown.n == len(pairs) and len(shown.updates) >= 3
    np.testing.assert_array_equal(free, pairs[checker.edges_free(Q0, Q1, r)])


def test_prismatic_certified_checks_are_one_chunk():
    """With a prismatic joint the certified bounds depend on the batch's largest |q|: the
    chunked call checks everything at once (one progress call) and equals one batch."""
    arm = mp.Arm.from_urdf(SLIDER_URDF)
    checker = CollisionChecker(arm, World([Box((0.2, 0.2, 0.2), (0.8, 0.0, 0.3))]))
    rng = np.random.default_rng(3)
    K = 100
    Q0 = rng.uniform(arm.lower_limits, arm.upper_limits, size=(K, arm.nq))
    Q1 = np.clip(Q0 + rng.uniform(-0.5, 0.5, size=Q0.shape), arm.lower_limits, arm.upper_limits)
    done: list[int] = []
    got = checker.edges_free(Q0, Q1, 0.1, progress=done.append)
    assert done == [K]
    np.testing.assert_array_equal(got, checker.edges_free(Q0, Q1, 0.1))


@pytest.fixture(scope="module")
def small_quickstart():
    """quickstart with 40 random nodes (a short lazy plan)."""
    scn = load_scenario("quickstart")
    return dataclasses.replace(scn, options=dataclasses.replace(scn.options, num_nodes=40))


def test_lazy_plan_shows_edge_checks_and_rounds(small_quickstart, capfd):
    """With progress, building the roadmap shows the edge checks and the lazy loop its
    rounds and the edges simulated; without, nothing reaches stderr."""
    scn = small_quickstart
    capfd.readouterr()
    setup = prepare(scn, show_progress=False)
    plan_path(scn, setup)
    quiet = capfd.readouterr()
    assert quiet.err == ""
    assert setup.lazy.count.rounds >= 2  # a loop worth showing

    eager_checks = dataclasses.replace(scn, collision="eager")
    setup = prepare(eager_checks, show_progress=True)
    built = capfd.readouterr().err
    assert f"edge checks: {_pairs(setup)} edges in " in built  # a log: one line
    assert setup.lazy.progress  # prepare(show_progress=True) passes it to LazyEdges
    plan_path(eager_checks, setup)
    err = capfd.readouterr().err
    assert "lazy search (energy)" in err and "rounds" in err
    assert "edges simulated" in err

    setup = prepare(scn, show_progress=True)  # lazy collision checks: in the rounds
    assert "edge checks" not in capfd.readouterr().err
    plan_path(scn, setup)
    err = capfd.readouterr().err
    assert f"{2 * setup.lazy.count.pairs_checked} edge checks" in err


def test_lazy_edge_bounds_show_a_bar_and_equal_one_call(small_quickstart, capfd,
                                                         monkeypatch):
    """The lazy roadmap's edge bounds run in chunks with an "edge bounds" bar (issue 34);
    the chunks give the same bounds, bit for bit, as one call over every edge."""
    import mpd_pin.planning.lazy as lazy

    monkeypatch.setattr(lazy, "BOUND_CHUNK", 97)  # several chunks on a small roadmap
    capfd.readouterr()
    setup = prepare(small_quickstart, show_progress=True)
    err = capfd.readouterr().err
    rm, le = setup.roadmap, setup.lazy
    assert rm.num_edges > 3 * 97
    assert re.search(rf"^edge bounds: {rm.num_edges} edges in \d+\.\d s$", err, re.M), err
    whole = le.bound(rm.nodes[rm.src], le._Q1, rm.durations)
    np.testing.assert_array_equal(le.lower, whole)
    setup = prepare(small_quickstart, show_progress=False)
    assert "edge bounds" not in capfd.readouterr().err


def _pairs(setup) -> int:
    """Candidate pairs of a setup's roadmap (the edge-check bar's total)."""
    arm, rm = setup.drive.arm, setup.roadmap
    return len(rmod._neighbour_pairs(rm.nodes, setup.lazy.options.k, arm.continuous_mask))


def test_refinement_shows_its_candidates(small_quickstart, capfd):
    """refine_candidates with progress shows a "refinement" bar naming the candidate and
    its step; without, it writes nothing to stderr (and the result is the same)."""
    scn = small_quickstart
    setup = prepare(scn, show_progress=False)
    path = plan_path(scn, setup).path
    assert len(path) >= 3  # something to shortcut
    cands = {"optimum": setup.roadmap.nodes[path]}
    opts = MotionOptions(max_rounds=1)
    capfd.readouterr()
    quiet = refine_candidates(setup.drive, setup.checker, scn.options, cands, opts)
    assert capfd.readouterr().err == ""
    shown = refine_candidates(setup.drive, setup.checker, scn.options, cands, opts,
                              progress=True)
    err = capfd.readouterr().err
    # not a terminal: one line, with the last step the bar showed
    assert re.search(r"^refinement: 1 candidate in \d+\.\d s \(optimum: pricing", err, re.M)
    assert "\r" not in err
    assert shown.motion.total_energy == quiet.motion.total_energy


def test_status_line_and_bar(capfd):
    """status(): a start line and a "done in" line on stderr, "stopped after" when the
    block raises, nothing when disabled; bar(): written only when enabled."""
    with status("plots"):
        pass
    err = capfd.readouterr().err.splitlines()
    assert err[0] == "mpd-pin: plots ..." and err[1].startswith("mpd-pin: plots done in ")
    with pytest.raises(RuntimeError), status("replay"):
        raise RuntimeError("boom")
    assert "mpd-pin: replay stopped after" in capfd.readouterr().err
    with status("plots", enabled=False), bar(5, "frames", enabled=False) as b:
        b.update(5)
    assert capfd.readouterr().err == ""
    with bar(5, "frames", unit="frame") as b:
        b.update(5)
    assert re.fullmatch(r"frames: 5 frames in \d+\.\d s\n", capfd.readouterr().err)


def test_cli_run_shows_every_long_phase_and_quiet_silences_them(tmp_path, capfd):
    """``mpd-pin run`` on a small quickstart: edge checks, the lazy search, verification,
    refinement, plots and replay each show on stderr; ``--quiet`` shows none of them."""
    from mpd_pin.app.cli import main

    args = ["run", "quickstart", "--nodes", "40", "--out"]
    capfd.readouterr()
    assert main([*args, str(tmp_path / "a"), "--quiet"]) == 0
    assert capfd.readouterr().err == ""
    assert main([*args, str(tmp_path / "b"), "--verify"]) == 0  # the opt-in phase shows too
    err = capfd.readouterr().err
    for phase in ("edge checks, ", "lazy search (energy)", "verification", "refinement",
                  "mpd-pin: plots done", "mpd-pin: replay done"):
        assert phase in err, phase
    assert "\r" not in err  # not a terminal: lines, no tqdm frames
    assert re.search(r"^lazy search \(energy\): \d+ rounds in \d+\.\d s \(\d+ edge checks, "
                     r"\d+ edges simulated\)$", err, re.M), err


def test_bar_lines_when_not_a_terminal():
    """Not a terminal: no frame, one line per bar when it closes, with its count (``n/total``
    when it stopped short), its units, its time and its postfix; "stopped at" when the block
    raised."""
    out = io.StringIO()
    with bar(3, "edge checks", unit="edge", file=out) as b:
        b.update(2)
    with bar(None, "lazy search (energy)", unit=" rounds", file=out) as r:
        r.update(1)
        r.set_postfix_str("4 edges simulated")
    with pytest.raises(KeyboardInterrupt), bar(10, "edge energies", unit="edge",
                                               file=out) as b:
        b.update(4)
        raise KeyboardInterrupt
    with bar(2, "refinement", unit="candidate", file=out, iterable=["a", "b"]) as shown:
        for _ in shown:
            pass
    lines = out.getvalue().splitlines()
    assert "\r" not in out.getvalue() and len(lines) == 4, lines
    assert re.fullmatch(r"edge checks: 2/3 edges in \d+\.\d s", lines[0])
    assert re.fullmatch(r"lazy search \(energy\): 1 round in \d+\.\d s \(4 edges simulated\)",
                        lines[1])
    assert re.fullmatch(r"edge energies: stopped at 4/10 edges after \d+\.\d s", lines[2])
    assert re.fullmatch(r"refinement: 2 candidates in \d+\.\d s", lines[3])


def _set_size(fd: int, columns: int, lines: int) -> None:
    fcntl.ioctl(fd, termios.TIOCSWINSZ, struct.pack("HHHH", lines, columns, 0, 0))


def _drain(fd: int, seconds: float = 0.2) -> bytes:
    """What can be read from ``fd`` now (until it stays silent for ``seconds``)."""
    got = b""
    while select.select([fd], [], [], seconds)[0]:
        try:
            chunk = os.read(fd, 65536)
        except OSError:  # EIO: the other side is closed
            break
        if not chunk:
            break
        got += chunk
    return got


def _pty_frames(size: tuple[int, int], monkeypatch) -> str:
    """A 20-step "edge checks" bar drawn with stderr on a pty of ``size`` (0 × 0: none
    reported), as the terminal received it."""
    master, slave = pty.openpty()
    got = b""
    try:
        if size != (0, 0):
            _set_size(slave, *size)
        with open(slave, "w", encoding="utf-8", closefd=False) as term:
            assert os.get_terminal_size(slave) == size
            with monkeypatch.context() as m:
                m.setattr(sys, "stderr", term)  # where bars go, as tqdm checks it
                with bar(20, "edge checks", unit="edge", mininterval=0) as b:
                    for _ in range(20):
                        b.update(1)
                        term.flush()
                        got += _drain(master, 0)  # keeps the pty's buffer from filling
            term.flush()
        got += _drain(master)
    finally:
        os.close(slave)
        os.close(master)
    return got.decode("utf-8", "replace")


@pytest.mark.parametrize("size", [(0, 0), (100, 30)], ids=["no-size", "100x30"])
def test_bar_draws_frames_on_a_pty(size, monkeypatch):
    """On a real pty a bar draws tqdm frames (``\\r``, a bar, ``n/total``, a rate) within the
    terminal's width and writes no log line: also on a pty that reports no size (0 × 0),
    where tqdm alone draws nothing (issue 34)."""
    text = _pty_frames(size, monkeypatch)
    frames = re.findall(r"\redge checks: +(\d+)%\|[^|\r]*\| (\d+)/20 \[[^\]\r]*edge/s\]",
                        text)
    assert len(frames) >= 10, repr(text[:500])
    assert frames[-1] == ("100", "20")
    width = size[0] or 80
    assert max(len(f) for f in text.split("\r")) < width
    assert "edge checks: 20 edges in" not in text  # the log line is for non-terminals


#: Roadmap nodes of the panda runs below: ≈1950 candidate pairs, whose edge checks take
#: 2 s on an idle core (5 s on a loaded 2-core machine), in several chunks.
PTY_NODES = 300


def _panda_pairs(num_nodes: int) -> int:
    """Candidate pairs (the "edge checks" total) of the panda roadmap with ``num_nodes``."""
    scn = load_scenario("panda")
    opts = dataclasses.replace(scn.options, num_nodes=num_nodes)
    checker = CollisionChecker(scn.arm, scn.world)
    nodes = rmod._sample_nodes(checker, scn.arm, scn.start, scn.goal, opts, rmod._tqdm(False),
                               False)
    return len(rmod._neighbour_pairs(nodes, opts.k, scn.arm.continuous_mask))


def _read_until(procs: dict[str, tuple[subprocess.Popen, int]], until: bytes,
                timeout: float) -> dict[str, bytes]:
    """Read the file descriptors of ``procs`` (name → (process, fd)) until each has sent
    ``until`` (or ended, or ``timeout`` s passed); then end the processes still running."""
    got = {name: b"" for name in procs}
    open_fds = {fd: name for name, (_, fd) in procs.items()}
    deadline = time.monotonic() + timeout
    try:
        while open_fds and time.monotonic() < deadline:
            ready, _, _ = select.select(list(open_fds), [], [], 0.5)
            for fd in ready:
                name = open_fds[fd]
                try:
                    chunk = os.read(fd, 65536)
                except OSError:  # EIO: the child closed the pty
                    chunk = b""
                got[name] += chunk
                if not chunk or until in got[name]:
                    del open_fds[fd]
    finally:
        for proc, _ in procs.values():
            if proc.poll() is None:
                proc.kill()
            proc.wait()
    return got


def test_cli_run_on_a_pty_draws_bars_and_on_a_pipe_writes_lines(tmp_path):
    """``python -m mpd_pin run panda --nodes 300 --collision eager`` with stderr on a real
    pty (no window size, as ``pty.openpty()`` makes it) draws tqdm frames for sampling, the
    edge checks (total = the roadmap's candidate pairs, growing counts, a rate) and the lazy
    search's rounds; the same command with stderr on a pipe writes no ``\\r`` and one line
    per phase with its count. Both are read until verification (``--verify``) starts (the
    roadmap phases), then ended."""
    argv = [sys.executable, "-m", "mpd_pin", "run", "panda", "--nodes", str(PTY_NODES),
            "--collision", "eager", "--no-replay", "--verify", "--out"]
    master, slave = pty.openpty()
    try:
        on_pty = subprocess.Popen([*argv, str(tmp_path / "pty")], stdin=slave, stdout=slave,
                                  stderr=slave, cwd=tmp_path)
    finally:
        os.close(slave)
    on_pipe = subprocess.Popen([*argv, str(tmp_path / "pipe")], stdin=subprocess.DEVNULL,
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                               cwd=tmp_path)
    try:
        pairs = _panda_pairs(PTY_NODES)  # while the two start
        got = _read_until({"pty": (on_pty, master), "pipe": (on_pipe, on_pipe.stderr.fileno())},
                          b"mpd-pin: verification ...", timeout=300)
    finally:
        os.close(master)
        on_pipe.stderr.close()
    term, log = (got[k].decode("utf-8", "replace") for k in ("pty", "pipe"))

    assert "mpd-pin: verification ..." in term, term[-2000:]
    assert "\rsampling: " in term and f"/{PTY_NODES} [" in term
    checks = [(int(n), int(total)) for n, total in re.findall(
        r"\redge checks: +\d+%\|[^|\r]*\| (\d+)/(\d+) \[[^\]\r]*(?:edge/s|s/edge)", term)]
    assert len(checks) >= 3, term[:3000]  # the first frame, then the checker's chunks
    assert {total for _, total in checks} == {pairs}
    counts = [n for n, _ in checks]
    assert counts == sorted(counts) and counts[-1] > counts[0]
    assert re.search(r"\rlazy search \(energy\): \d+ rounds \[", term)
    assert "edge checks: " + str(pairs) + " edges in" not in term  # no log line on a pty

    assert "mpd-pin: verification ..." in log, log
    assert "\r" not in log
    assert re.search(rf"^sampling: {PTY_NODES} nodes in \d+\.\d s$", log, re.M), log
    assert re.search(rf"^edge checks: {pairs} edges in \d+\.\d s$", log, re.M), log
    assert re.search(r"^lazy search \(energy\): \d+ rounds? in \d+\.\d s \(\d+ edges "
                     r"simulated\)$", log, re.M), log
