"""Roadmap: sampling, connections, edge checks, directed energy costs, files (docs/design.md §4)."""

import hashlib
import math

import numpy as np
import pytest
from planar_geometry import min_signed_distance

import mpd_pin as mp
from mpd_pin.collision import CollisionChecker
from mpd_pin.dynamics import EnergyCost
from mpd_pin.planning.roadmap import Roadmap, RoadmapOptions, build_roadmap
from mpd_pin.world import Box, Cylinder, World

START = np.array([0.6, 0.3, 0.2])
GOAL = np.array([2.4, -0.3, -0.2])
OPTIONS = RoadmapOptions(num_nodes=50, k=6, seed=3, resolution=0.05, duration=0.5, dt=0.01)


@pytest.fixture(scope="module")
def setup():
    arm = mp.builtin_arm("planar_3link")
    drive = mp.Drive(arm, mp.PAPER_MOTOR.with_gear_ratio(5.0), kp=40.0, kd=4.0)
    world = World(
        (
            Box.planar((0.0, 0.9), 0.3, 0.4, name="wall"),
            Cylinder.planar((-0.7, -0.4), 0.15, name="post"),
        )
    )
    checker = CollisionChecker(arm, world)
    cost = EnergyCost(drive, OPTIONS.dt)
    rm = build_roadmap(cost, checker, START, GOAL, OPTIONS, show_progress=False)
    return arm, drive, world, checker, cost, rm


def test_structure_and_costs(setup):
    arm, drive, world, checker, cost, rm = setup
    assert rm.num_nodes == OPTIONS.num_nodes + 2
    np.testing.assert_array_equal(rm.nodes[rm.start], START)
    np.testing.assert_array_equal(rm.nodes[rm.goal], GOAL)
    assert np.all(checker.is_free_batch(rm.nodes))
    assert np.all(rm.nodes >= arm.lower_limits) and np.all(rm.nodes <= arm.upper_limits)
    # Both directions of every edge, no self loops, no duplicates.
    pairs = set(zip(rm.src.tolist(), rm.dst.tolist(), strict=True))
    assert len(pairs) == rm.num_edges
    assert all((v, u) in pairs for u, v in pairs)
    assert np.all(rm.src != rm.dst)
    # Every node's k nearest neighbours are candidates: edges only join near nodes.
    dist = np.linalg.norm(rm.nodes[rm.src] - rm.nodes[rm.dst], axis=1)
    kth = np.sort(np.linalg.norm(rm.nodes[:, None] - rm.nodes[None], axis=2), axis=1)[:, OPTIONS.k]
    assert np.all((dist <= kth[rm.src] + 1e-12) | (dist <= kth[rm.dst] + 1e-12))
    # Directed costs are the simulated E⁺ of each direction.
    for e in [0, 1, rm.num_edges // 2, rm.num_edges - 1]:
        sim = mp.simulate_edge(
            drive, rm.nodes[rm.src[e]], rm.nodes[rm.dst[e]], rm.durations[e], OPTIONS.dt
        )
        np.testing.assert_allclose(rm.energy[e], sim.energy, rtol=1e-8)
    g = rm.graph()
    assert g.num_edges == rm.num_edges
    assert g.cost(int(rm.src[0]), int(rm.dst[0])) == pytest.approx(rm.cost[0], rel=1e-15)
    assert np.all(rm.cost > 0)


@pytest.fixture(scope="module")
def big(setup):
    """A 400-node, k = 10 roadmap in the same world (~4400 directed edges)."""
    arm, drive, world, checker, cost, rm = setup
    opts = RoadmapOptions(num_nodes=400, k=10, seed=5, resolution=0.05, duration=0.5, dt=0.01)
    return opts, build_roadmap(cost, checker, START, GOAL, opts, show_progress=False)


def _fine_samples(nodes, pairs, step):
    """Configurations along each edge (a, b) of ``pairs`` with joint step ≤ ``step`` (rad),
    both ends included, and the edge index of each."""
    Q, owner = [], []
    for e, (a, b) in enumerate(pairs):
        q0, q1 = nodes[a], nodes[b]
        m = max(1, math.ceil(np.abs(q1 - q0).max() / step))
        Q.append(q0 + np.linspace(0.0, 1.0, m + 1)[:, None] * (q1 - q0))
        owner.append(np.full(m + 1, e))
    return np.concatenate(Q), np.concatenate(owner)


def test_no_accepted_edge_collides_at_ten_times_finer_resolution(setup, big):
    """Every accepted edge, sampled at resolution / 10, is free for the checker's discrete
    mode and for the independent exact 2-D geometry (tests/planar_geometry.py)."""
    arm, drive, world, checker, cost, rm = setup
    opts, rm = big
    spec = mp.BUILTIN_ARMS["planar_3link"]
    fine = opts.resolution / 10
    pairs = sorted({(int(u), int(v)) for u, v in zip(rm.src, rm.dst, strict=True) if u < v})
    assert len(pairs) == rm.num_edges // 2 > 2000
    Q0, Q1 = rm.nodes[[a for a, _ in pairs]], rm.nodes[[b for _, b in pairs]]
    assert checker.edges_free(Q0, Q1, fine, mode="discrete").all()
    Q, owner = _fine_samples(rm.nodes, pairs, fine)
    assert len(Q) > 100 * len(pairs)
    assert checker.is_free_batch(Q).all()
    sd = min_signed_distance(Q, spec.lengths, spec.radius, world)
    assert np.all(sd > 0), [pairs[e] for e in np.unique(owner[sd <= 0])]
    # Informative: the k-nearest candidates the check rejected (computed here by brute
    # force) collide in the exact geometry, and some accepted edges pass close by.
    n = rm.num_nodes
    dist = np.linalg.norm(rm.nodes[:, None] - rm.nodes[None], axis=2)
    nbr = np.argsort(dist, axis=1)[:, 1 : opts.k + 1]
    candidates = {(min(a, int(b)), max(a, int(b))) for a in range(n) for b in nbr[a]}
    assert set(pairs) <= candidates
    rejected = sorted(candidates - set(pairs))
    assert len(rejected) > 50
    Qr, owner_r = _fine_samples(rm.nodes, rejected, fine)
    hit = np.zeros(len(rejected), dtype=bool)
    np.logical_or.at(hit, owner_r, min_signed_distance(Qr, spec.lengths, spec.radius, world) <= 0)
    assert hit.all(), [rejected[e] for e in np.flatnonzero(~hit)]
    assert sd.min() < 1e-3


def test_same_seed_same_roadmap_other_seed_differs(setup):
    arm, drive, world, checker, cost, rm = setup
    again = build_roadmap(cost, checker, START, GOAL, OPTIONS, show_progress=False)
    for name in ("nodes", "src", "dst", "durations", "energy"):
        np.testing.assert_array_equal(getattr(again, name), getattr(rm, name))
    assert again.key == rm.key
    other = RoadmapOptions(**{**OPTIONS.__dict__, "seed": 4})
    diff = build_roadmap(cost, checker, START, GOAL, other, show_progress=False)
    assert diff.key != rm.key
    assert diff.key == Roadmap.key_for(cost, checker.fingerprint(), other, START, GOAL)
    # other samples (start and goal stay nodes 0 and 1), none shared
    np.testing.assert_array_equal(diff.nodes[:2], rm.nodes[:2])
    assert diff.nodes.shape == rm.nodes.shape
    gap = np.linalg.norm(diff.nodes[2:, None] - rm.nodes[None, 2:], axis=2)
    assert gap.min() > 1e-6
    assert np.all(checker.is_free_batch(diff.nodes))


def test_progress_bars_on_stderr(setup, capsys):
    arm, drive, world, checker, cost, rm = setup
    opts = RoadmapOptions(num_nodes=10, k=3, seed=7, duration=0.5, dt=0.01)
    quiet = build_roadmap(cost, checker, START, GOAL, opts, show_progress=False)
    assert capsys.readouterr().err == ""
    loud = build_roadmap(cost, checker, START, GOAL, opts, show_progress=True)
    err = capsys.readouterr().err
    # stderr is not a terminal here: one line per phase, with its count (§8a)
    assert f"sampling: {opts.num_nodes} nodes in" in err and "\r" not in err, err
    assert f"edge energies: {loud.num_edges} edges in" in err, err
    np.testing.assert_array_equal(loud.energy, quiet.energy)


def test_save_load_and_refusals(setup, tmp_path):
    arm, drive, world, checker, cost, rm = setup
    path = rm.save(tmp_path / "rm.npz")
    back = Roadmap.load(path, expected_key=rm.key)
    for name in ("nodes", "src", "dst", "durations", "energy"):
        np.testing.assert_array_equal(getattr(back, name), getattr(rm, name))
    # The cache path of build_roadmap reuses a matching file ...
    cached = build_roadmap(cost, checker, START, GOAL, OPTIONS, cache=path, show_progress=False)
    np.testing.assert_array_equal(cached.energy, rm.energy)
    # ... and refuses one built with other parameters.
    other_drive = mp.Drive(arm, mp.PAPER_MOTOR.with_gear_ratio(6.0), kp=40.0, kd=4.0)
    with pytest.raises(ValueError, match="other parameters"):
        build_roadmap(
            EnergyCost(other_drive, OPTIONS.dt),
            checker,
            START,
            GOAL,
            OPTIONS,
            cache=path,
            show_progress=False,
        )
    # A tampered file is refused.
    with np.load(path) as f:
        data = {k: f[k] for k in f.files}
    data["energy"] = data["energy"] * 0.5
    np.savez(tmp_path / "bad.npz", **data)
    with pytest.raises(ValueError, match="modified"):
        Roadmap.load(tmp_path / "bad.npz")
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(ValueError, match="cannot read"):
        Roadmap.load(tmp_path / "junk.npz")


def test_key_covers_checker_settings(setup, tmp_path):
    """Every checker setting that changes the free space changes the key; loading refuses."""
    arm, drive, world, checker, cost, rm = setup
    from mpd_pin.world import Hazard, Polygon, Sphere

    hot = Hazard(Polygon.planar([(-1.1, 0.9), (-0.8, 0.9), (-0.95, 1.1)], name="hot"), 0.05)
    late = Sphere.planar((1.0, -0.9), 0.1, name="late", hidden=True)

    def scene():
        return World((*world.obstacles, late), (hot,))

    opts = RoadmapOptions(num_nodes=8, k=3, seed=1, duration=0.5, dt=0.01)
    base = CollisionChecker(arm, scene())
    path = build_roadmap(cost, base, START, GOAL, opts, cache=tmp_path / "rm.npz",
                         show_progress=False)
    assert path.key == Roadmap.key_for(cost, base.fingerprint(), opts, START, GOAL)
    # Deterministic, and blind to what does not change answers.
    same = [CollisionChecker(arm, scene()), CollisionChecker(arm, scene(), num_threads=1),
            CollisionChecker(arm, scene(), single_backend="broadphase"),
            CollisionChecker(arm, scene(), self_collision=True)]
    assert {c.fingerprint() for c in same} == {base.fingerprint()}
    assert len(base.fingerprint()) == 64
    revealed = CollisionChecker(arm, scene())
    revealed.reveal("late")
    variants = {
        "margin": CollisionChecker(arm, scene(), margin=0.001),
        "hazard_clearance": CollisionChecker(arm, scene(), hazard_clearance=True),
        "self_collision": CollisionChecker(arm, scene(), self_collision=False),
        "edge_mode": CollisionChecker(arm, scene(), edge_mode="discrete"),
        "min_step": CollisionChecker(arm, scene(), min_step=1e-5),
        "include_hidden": CollisionChecker(arm, scene(), include_hidden=True),
        "revealed": revealed,
        "world": CollisionChecker(arm, world),
    }
    assert base.describe()["self_pairs"] == [["link1_0", "link3_0"]]
    assert variants["self_collision"].describe()["self_pairs"] == []
    keys = {n: Roadmap.key_for(cost, c.fingerprint(), opts, START, GOAL)
            for n, c in variants.items()}
    assert len(set(keys.values()) | {path.key}) == len(variants) + 1, keys
    for name, c in variants.items():
        with pytest.raises(ValueError, match="other parameters"):
            build_roadmap(cost, c, START, GOAL, opts, cache=tmp_path / "rm.npz",
                          show_progress=False)
        assert c.fingerprint() != base.fingerprint(), name
    # A checker that cannot describe itself needs an explicit fingerprint.

    class Bare:
        arm = checker.arm
        is_free = staticmethod(checker.is_free)
        is_free_batch = staticmethod(checker.is_free_batch)
        edges_free = staticmethod(checker.edges_free)

    with pytest.raises(ValueError, match="no fingerprint"):
        build_roadmap(cost, Bare(), START, GOAL, opts, show_progress=False)
    bare = build_roadmap(cost, Bare(), START, GOAL, opts, checker_fingerprint="mine",
                         show_progress=False)
    assert bare.key == Roadmap.key_for(cost, "mine", opts, START, GOAL)


def test_cache_path_without_npz_suffix(setup, tmp_path):
    arm, drive, world, checker, cost, rm = setup
    saved = rm.save(tmp_path / "a")
    assert saved == tmp_path / "a.npz" and saved.is_file() and not (tmp_path / "a").exists()
    for path in (tmp_path / "a", str(tmp_path / "a"), tmp_path / "a.npz"):
        hit = build_roadmap(cost, checker, START, GOAL, OPTIONS, cache=path, show_progress=False)
        assert hit.timings == {}  # loaded, not built
        np.testing.assert_array_equal(hit.energy, rm.energy)
        np.testing.assert_array_equal(Roadmap.load(path, expected_key=rm.key).nodes, rm.nodes)
    built = build_roadmap(cost, checker, START, GOAL, OPTIONS, cache=tmp_path / "b",
                          show_progress=False)
    assert built.timings and (tmp_path / "b.npz").is_file() and not (tmp_path / "b").exists()
    again = build_roadmap(cost, checker, START, GOAL, OPTIONS, cache=tmp_path / "b",
                          show_progress=False)
    assert again.timings == {}
    np.testing.assert_array_equal(again.src, built.src)


def test_corrupt_file_is_refused_clearly(setup, tmp_path):
    arm, drive, world, checker, cost, rm = setup
    good = rm.save(tmp_path / "good.npz").read_bytes()
    cases = {
        "trunc.npz": good[: len(good) // 2],
        "tail.npz": good[:-30],
        "empty.npz": b"",
        # one byte of the compressed data flipped (zlib or CRC error)
        "flip.npz": good[:400] + bytes([good[400] ^ 0xFF]) + good[401:],
    }
    for name, data in cases.items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(ValueError, match=f"cannot read roadmap file .*{name}"):
            Roadmap.load(tmp_path / name)
        with pytest.raises(ValueError, match=f"cannot read roadmap file .*{name}"):
            build_roadmap(cost, checker, START, GOAL, OPTIONS, cache=tmp_path / name,
                          show_progress=False)
    np.save(tmp_path / "plain.npy", np.zeros(3))
    with pytest.raises(ValueError, match="not an .npz archive"):
        Roadmap.load(tmp_path / "plain.npy")
    with pytest.raises(ValueError, match="cannot read roadmap file .*missing.npz"):
        Roadmap.load(tmp_path / "missing")


def _resave_with_valid_checksum(path, data):
    """Write ``data`` (the .npz fields) with a checksum recomputed as the format defines it:
    SHA-256 of the key, then of each array (sorted by name) as "name:dtype:shape" + bytes."""
    names = ("nodes", "endpoints", "src", "dst", "durations", "energy", "edge_counts")
    names += tuple(n for n in ("checked", "bus") if n in data)  # optional arrays
    h = hashlib.sha256(str(data["key"]).encode())
    for name in sorted(names):
        a = np.ascontiguousarray(data[name])
        h.update(f"{name}:{a.dtype.str}:{a.shape}".encode())
        h.update(a.tobytes())
    np.savez(path, **{**data, "checksum": np.array(h.hexdigest())})
    return path


CRAFTED = {
    "bus of 3 columns": (lambda d, n: {"bus": np.zeros((d["src"].size, 3))}, "bus must be"),
    "negative bus": (lambda d, n: {"bus": np.r_[[[-1.0, 0.0]], d["bus"][1:]]},
                     "bus energies must be >= 0"),
    "bus NaN on an evaluated edge": (lambda d, n: {"bus": np.r_[[[np.nan, 0.0]], d["bus"][1:]]},
                                     "NaN exactly where"),
    "src id too large": (lambda d, n: {"src": np.r_[n, d["src"][1:]]}, "node ids outside"),
    "negative dst id": (lambda d, n: {"dst": np.r_[d["dst"][:3], -1, d["dst"][4:]]},
                        "node ids outside"),
    "goal id too large": (lambda d, n: {"endpoints": np.array([0, n + 3])}, "node ids outside"),
    "three endpoints": (lambda d, n: {"endpoints": np.array([0, 1, 2])}, "endpoints"),
    "float edge ids": (lambda d, n: {"src": d["src"].astype(float)}, "integer"),
    "negative energy": (lambda d, n: {"energy": d["energy"] * np.r_[-1, np.ones(2)]},
                        "energies must be finite and >= 0"),
    # NaN in one joint only (a row of NaN is an edge not yet evaluated: §4f)
    "nan energy": (lambda d, n: {"energy": d["energy"] * np.r_[np.nan, np.ones(2)]},
                   "energies must be finite"),
    "inf energy": (lambda d, n: {"energy": d["energy"] * np.r_[np.inf, np.ones(2)]},
                   "energies must be finite"),
    "zero duration": (lambda d, n: {"durations": d["durations"] * 0}, "durations"),
    "short durations": (lambda d, n: {"durations": d["durations"][:-1]}, "edges but"),
    "energy of 2 joints": (lambda d, n: {"energy": d["energy"][:, :2]}, "edges but"),
    "infinite node": (lambda d, n: {"nodes": d["nodes"] * np.inf}, "NaN or infinity"),
    "flat nodes": (lambda d, n: {"nodes": d["nodes"].ravel()}, "nodes must be"),
    "self loop": (lambda d, n: {"dst": d["src"].copy()}, "self-loop"),
    "negative edge count": (lambda d, n: {"edge_counts": np.array([0, -1, 0])}, "edge_counts"),
    "two edge counts": (lambda d, n: {"edge_counts": np.array([0, 0])}, "edge_counts"),
}


@pytest.mark.parametrize("case", sorted(CRAFTED))
def test_crafted_file_with_valid_checksum_is_refused(setup, tmp_path, case):
    arm, drive, world, checker, cost, rm = setup
    with np.load(rm.save(tmp_path / "rm.npz")) as f:
        data = {k: f[k] for k in f.files}
    # the recomputed checksum is the real one: unchanged contents load
    ok = _resave_with_valid_checksum(tmp_path / "same.npz", data)
    np.testing.assert_array_equal(Roadmap.load(ok, expected_key=rm.key, nq=3).energy, rm.energy)
    change, match = CRAFTED[case]
    path = _resave_with_valid_checksum(tmp_path / "bad.npz", {**data, **change(data, rm.num_nodes)})
    with pytest.raises(ValueError, match=f"bad.npz' is inconsistent: .*{match}"):
        Roadmap.load(path, expected_key=rm.key)
    with pytest.raises(ValueError, match="is inconsistent"):
        build_roadmap(cost, checker, START, GOAL, OPTIONS, cache=path, show_progress=False)


def test_configurations_of_other_arm_are_refused(setup, tmp_path):
    """A consistent 2-joint roadmap under the 3-link arm's key: loads alone, refused for nq=3."""
    arm, drive, world, checker, cost, rm = setup
    with np.load(rm.save(tmp_path / "rm.npz")) as f:
        data = {k: f[k] for k in f.files}
    two = {**data, "nodes": data["nodes"][:, :2], "energy": data["energy"][:, :2]}
    path = _resave_with_valid_checksum(tmp_path / "two.npz", two)
    assert Roadmap.load(path).nodes.shape == (rm.num_nodes, 2)
    with pytest.raises(ValueError, match="nodes have 2 joint values, the arm has 3"):
        Roadmap.load(path, nq=3)
    with pytest.raises(ValueError, match="nodes have 2 joint values, the arm has 3"):
        build_roadmap(cost, checker, START, GOAL, OPTIONS, cache=path, show_progress=False)


def test_path_energy_is_sum_of_edges(setup):
    rm = setup[-1]
    from mpd_pin.search import Dijkstra

    p = Dijkstra(rm.graph(), rm.start, rm.goal).plan()
    E = rm.path_energy(p.nodes)
    assert E.sum() == pytest.approx(p.cost, rel=1e-12)
    with pytest.raises(ValueError, match="not in the roadmap"):
        rm.path_energy([rm.start, rm.start])


def test_bad_start_goal(setup):
    arm, drive, world, checker, cost, rm = setup
    in_wall = np.array([1.5708, 0.0, 0.0])  # straight up through the wall
    assert not checker.is_free(in_wall)
    with pytest.raises(ValueError, match="start .* is in collision"):
        build_roadmap(cost, checker, in_wall, GOAL, OPTIONS, show_progress=False)
    with pytest.raises(ValueError, match="goal .* outside the joint limits"):
        build_roadmap(cost, checker, START, np.array([4.0, 0, 0]), OPTIONS, show_progress=False)
    with pytest.raises(ValueError, match="NaN"):
        build_roadmap(cost, checker, np.array([np.nan, 0, 0]), GOAL, OPTIONS, show_progress=False)
    with pytest.raises(ValueError, match="goal .* is in collision"):
        build_roadmap(cost, checker, START, in_wall, OPTIONS, show_progress=False)
    below = START.copy()
    below[1] = arm.lower_limits[1] - 0.01
    with pytest.raises(ValueError, match="start .* outside the joint limits"):
        build_roadmap(cost, checker, below, GOAL, OPTIONS, show_progress=False)
    with pytest.raises(ValueError, match="start must have 3 joint values"):
        build_roadmap(cost, checker, START[:2], GOAL, OPTIONS, show_progress=False)


def test_checker_of_another_arm_is_refused(setup):
    arm, drive, world, checker, cost, rm = setup
    other = CollisionChecker(mp.builtin_arm("planar_4link"), world)
    with pytest.raises(ValueError, match="checker's arm .*planar_4link.* is not the arm"):
        build_roadmap(cost, other, START, GOAL, OPTIONS, show_progress=False)
    # a 3-link arm that differs only in its last link's length: refused too
    longer = mp.Arm.from_urdf(mp.planar_arm_urdf([0.5, 0.4, 0.35], [0.5, 0.4, 0.3]))
    with pytest.raises(ValueError, match="is not the arm"):
        build_roadmap(cost, CollisionChecker(longer, world), START, GOAL, OPTIONS,
                      show_progress=False)
    # an identical arm loaded again is accepted (equal fingerprint)
    twin = mp.builtin_arm("planar_3link")
    assert twin is not arm and twin.fingerprint() == arm.fingerprint()
    again = build_roadmap(cost, CollisionChecker(twin, world), START, GOAL, OPTIONS,
                          show_progress=False)
    assert again.key == rm.key


def test_duration_rule():
    opt = RoadmapOptions(
        duration_rule="distance",
        joint_speed=1.0,
        duration_quantum=0.25,
        min_duration=0.5,
        max_duration=2.0,
        dt=0.005,
    )
    Q0 = np.zeros((4, 2))
    Q1 = np.array([[0.1, 0.0], [0.0, 0.76], [1.3, -0.2], [5.0, 0.0]])
    np.testing.assert_allclose(opt.durations(Q0, Q1), [0.5, 1.0, 1.5, 2.0])
    with pytest.raises(ValueError, match="duration_rule"):
        RoadmapOptions(duration_rule="slow")
    with pytest.raises(ValueError, match="whole number"):
        RoadmapOptions(duration=0.5, dt=0.003)


def test_sampling_gives_up_clearly():
    arm = mp.builtin_arm("planar_2link")
    drive = mp.Drive(arm, mp.PAPER_MOTOR, kp=1.0, kd=0.1)
    # A ring of boxes around the base leaves (almost) no free configuration.
    world = World(
        tuple(
            Box.planar((0.35 * np.cos(a), 0.35 * np.sin(a)), 0.3, 0.3, angle=a, name=f"b{i}")
            for i, a in enumerate(np.linspace(0, 2 * np.pi, 12, endpoint=False))
        )
    )
    checker = CollisionChecker(arm, World())
    blocked = CollisionChecker(arm, world)
    start, goal = np.array([0.0, 0.0]), np.array([1.0, 0.0])
    assert checker.is_free(start)
    opts = RoadmapOptions(num_nodes=20, max_attempts=3)

    class Wrapper:
        """Endpoints valid in an empty world, samples checked in the blocked one."""

        arm = checker.arm
        fingerprint = staticmethod(checker.fingerprint)
        is_free = staticmethod(checker.is_free)
        is_free_batch = staticmethod(blocked.is_free_batch)
        edges_free = staticmethod(blocked.edges_free)

    with pytest.raises(ValueError, match="free space is too small"):
        build_roadmap(EnergyCost(drive), Wrapper(), start, goal, opts, show_progress=False)


def test_velocity_timing_is_the_smallest_quantum_multiple_within_the_limit():
    """RoadmapOptions.timing against brute force: T is the rule's duration, or the smallest
    multiple of the quantum at which the quintic's peak speed 1.875·|Δq|/T is within every
    joint's limit (joints without a positive finite limit unconstrained)."""
    rng = np.random.default_rng(11)
    Q0 = rng.uniform(-2, 2, (300, 3))
    Q1 = Q0 + rng.normal(0.0, 1.0, (300, 3))
    vlim = np.array([2.0, 0.0, 3.0])  # joint 2 has no limit in its URDF
    for opts in (OPTIONS, RoadmapOptions(duration_rule="distance", joint_speed=2.0)):
        T, raised = opts.timing(Q0, Q1, vlim)
        base = opts.timing(Q0, Q1, None)[0]
        for k in range(len(Q0)):
            t = base[k]
            cand = [t] + [m * opts.duration_quantum for m in range(1, 400)]
            ok = [c for c in cand if c >= t - 1e-12 and all(
                1.875 * abs(Q1[k, j] - Q0[k, j]) / c <= vlim[j] * (1 + 1e-9) for j in (0, 2))]
            assert T[k] == pytest.approx(min(ok), abs=1e-12)
            assert raised[k] == (T[k] > base[k] + 1e-12)
        assert raised.any() and not raised.all()


def test_edges_a_weak_motor_cannot_follow_are_refused_not_costed():
    """A PD-only drive behind a saturated weak supply misses many nodes: those edges are
    refused and counted; every kept edge, re-simulated, ends within the tolerance, and the
    refused ones really miss (checked on a sample by simulate_edge)."""
    arm = mp.builtin_arm("planar_3link")
    motor = mp.DCMotor(R=1.0, L=0.5, Kt=0.01, Ke=0.02, B=0.1, J=0.01, gear_ratio=5.0, v_max=30.0)
    drive = mp.Drive(arm, motor, kp=40.0, kd=4.0, feedforward=False)
    checker = CollisionChecker(arm, World(()))
    rm = build_roadmap(EnergyCost(drive, OPTIONS.dt), checker, START, GOAL, OPTIONS,
                       show_progress=False)
    counts = rm.edge_counts
    assert counts["refused_arrival"] > 0 and counts["refused_effort"] == 0
    for e in range(0, rm.num_edges, max(1, rm.num_edges // 15)):
        sim = mp.simulate_edge(drive, rm.nodes[rm.src[e]], rm.nodes[rm.dst[e]],
                               rm.durations[e], OPTIONS.dt)
        assert np.abs(sim.q[-1] - rm.nodes[rm.dst[e]]).max() <= OPTIONS.arrival_tolerance
    free = build_roadmap(EnergyCost(drive, OPTIONS.dt), checker, START, GOAL,
                         RoadmapOptions(**{**OPTIONS.__dict__, "arrival_tolerance": math.pi}),
                         show_progress=False)
    kept = set(zip(rm.src.tolist(), rm.dst.tolist(), strict=True))
    refused = [e for e, uv in enumerate(zip(free.src.tolist(), free.dst.tolist(), strict=True))
               if uv not in kept]
    assert len(refused) == counts["refused_arrival"]
    for e in refused[:: max(1, len(refused) // 10)]:
        sim = mp.simulate_edge(drive, free.nodes[free.src[e]], free.nodes[free.dst[e]],
                               free.durations[e], OPTIONS.dt)
        assert np.abs(sim.q[-1] - free.nodes[free.dst[e]]).max() > OPTIONS.arrival_tolerance


def test_effort_limit_refuses_edges_whose_torque_exceeds_it(tmp_path):
    """With the URDF effort limit lowered below what the motion needs, the edges whose
    simulated peak n·Kt·|i| exceeds it are refused (counted), and no kept edge exceeds it."""
    xml = mp.builtin_arm_urdf("planar_3link").replace('effort="100', 'effort="4')
    arm = mp.Arm.from_urdf(xml)
    assert np.all(arm.model.effortLimit == 4.0)
    drive = mp.Drive(arm, mp.PAPER_MOTOR.with_gear_ratio(5.0), kp=40.0, kd=4.0)
    rm = build_roadmap(EnergyCost(drive, OPTIONS.dt), CollisionChecker(arm, World(())),
                       START, GOAL, OPTIONS, show_progress=False)
    assert rm.edge_counts["refused_effort"] > 0
    out = mp.dynamics.edge_outcomes(drive, rm.nodes[rm.src], rm.nodes[rm.dst], rm.durations,
                                    OPTIONS.dt)
    assert out.peak_torque.max() <= 4.0


def test_scenario_roadmap_feasibility_keys():
    from mpd_pin.app.config import ConfigError
    from mpd_pin.app.scenario import builtin_scenarios, load_scenario_data, parse_energy_scenario

    data = load_scenario_data(builtin_scenarios()["case1"])
    scn = parse_energy_scenario(data)
    assert scn.options.velocity_limits and scn.options.effort_limits
    assert scn.options.arrival_tolerance == 0.01
    data["roadmap"].update(velocity_limits=False, effort_limits=False, arrival_tolerance=0.05)
    opts = parse_energy_scenario(data).options
    assert (opts.velocity_limits, opts.effort_limits, opts.arrival_tolerance) == (
        False, False, 0.05)
    data["roadmap"]["arrival_tolerance"] = -1.0
    with pytest.raises(ConfigError, match=r"roadmap\.arrival_tolerance"):
        parse_energy_scenario(data)
