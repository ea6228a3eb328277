"""Progress on long runs (issue 23): every long phase shows a bar or a status line on
stderr, and nothing is written there when progress is off.

References: one unchunked ``edges_free`` call for the chunked edge checks (same mask, same
certification counts); stderr as captured by pytest (``capfd``) for the bars."""

from __future__ import annotations

import dataclasses

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
    assert "edge checks" in built and f"/{_pairs(setup)}" in built
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
    assert "refinement" in err and "optimum: shortcut" in err and "/1" in err
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
    assert "frames" in capfd.readouterr().err


def test_cli_run_shows_every_long_phase_and_quiet_silences_them(tmp_path, capfd):
    """``mpd-pin run`` on a small quickstart: edge checks, the lazy search, verification,
    refinement, plots and replay each show on stderr; ``--quiet`` shows none of them."""
    from mpd_pin.app.cli import main

    args = ["run", "quickstart", "--nodes", "40", "--out"]
    capfd.readouterr()
    assert main([*args, str(tmp_path / "a"), "--quiet"]) == 0
    assert capfd.readouterr().err == ""
    assert main([*args, str(tmp_path / "b")]) == 0
    err = capfd.readouterr().err
    for phase in ("edge checks, ", "lazy search (energy)", "verification", "refinement",
                  "mpd-pin: plots done", "mpd-pin: replay done"):
        assert phase in err, phase
