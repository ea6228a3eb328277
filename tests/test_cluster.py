"""Executors and clusters (docs/design.md §4h): a real LocalCluster of two worker processes
on loopback gives the in-process energies bit for bit, survives a killed worker; roadmap
files are atomic and an interrupted eager build resumes to the same file."""

import concurrent.futures as cf
import json
import logging
import os
import signal
import socket
from dataclasses import fields

import distributed  # a declared dependency: a plain import, never a skip
import numpy as np
import pytest

import mpd_pin as mp
from mpd_pin.app.cli import main
from mpd_pin.collision import CollisionChecker
from mpd_pin.dynamics import EnergyCost, edge_outcomes
from mpd_pin.dynamics import remote as rmt
from mpd_pin.dynamics.simulate import EdgeOutcomes
from mpd_pin.planning import resume as rs
from mpd_pin.planning import roadmap as rmod
from mpd_pin.planning.roadmap import Roadmap, RoadmapOptions, build_roadmap
from mpd_pin.world import Box, Cylinder, World

START = np.array([0.6, 0.3, 0.2])
GOAL = np.array([2.4, -0.3, -0.2])
# Distance rule: edges of several durations (0.5 … 1.25 s), i.e. several integrator batches.
OPTIONS = RoadmapOptions(num_nodes=120, k=8, seed=7, duration_rule="distance", dt=0.01)


@pytest.fixture(scope="module")
def scene():
    arm = mp.builtin_arm("planar_3link")
    drive = mp.Drive(arm, mp.PAPER_MOTOR.with_gear_ratio(5.0), kp=40.0, kd=4.0)
    world = World((Box.planar((0.0, 0.9), 0.3, 0.4, name="wall"),
                   Cylinder.planar((-0.7, -0.4), 0.15, name="post")))
    checker = CollisionChecker(arm, world)
    ref = build_roadmap(EnergyCost(drive, OPTIONS.dt), checker, START, GOAL, OPTIONS,
                        show_progress=False)
    assert len(np.unique(ref.durations)) >= 2 and ref.num_edges > 600
    return drive, checker, ref


@pytest.fixture(scope="module")
def client():
    """A real LocalCluster: 2 worker processes × 1 thread on 127.0.0.1, with nannies."""
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       host="127.0.0.1", dashboard_address=":0",
                                       silence_logs=logging.ERROR)
    cl = distributed.Client(cluster)
    yield cl
    cl.close()
    cluster.close()


class _CountingBar:
    """A stand-in progress bar that counts (tqdm does not when disabled)."""

    def __init__(self, *args, total=None, **kw):
        self.n = 0

    def update(self, n=1):
        self.n += n

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def _same_roadmap(a: Roadmap, b: Roadmap) -> None:
    assert a.key == b.key
    for name in ("nodes", "src", "dst", "durations", "energy"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    assert a.edge_counts == b.edge_counts


def test_chunks_give_the_rows_of_the_whole_batch(scene):
    """edge_outcomes of every chunk of plan_chunks == the rows of one whole-batch call."""
    drive, _, ref = scene
    Q0, Q1, T = ref.nodes[ref.src], ref.nodes[ref.dst], ref.durations
    whole = edge_outcomes(drive, Q0, Q1, T, OPTIONS.dt)
    for size in (1, 37, 256):
        chunks = rmt.plan_chunks(T, OPTIONS.dt, size)
        assert np.array_equal(np.sort(np.concatenate(chunks)), np.arange(T.size))
        for rows in chunks[:: max(1, len(chunks) // 12)]:
            part = edge_outcomes(drive, Q0[rows], Q1[rows], T[rows], OPTIONS.dt, threads=1)
            for f in fields(EdgeOutcomes):
                assert np.array_equal(getattr(part, f.name), getattr(whole, f.name)[rows])


def test_drive_spec_rebuilds_the_same_dynamics():
    """Plain data (URDF text, locked joints, motors, gains) → a drive with bit-identical
    energies, also for an example-robot-data arm with locked finger joints."""
    arm = mp.Arm.from_example_robot_data("panda")
    drive = mp.Drive(arm, mp.sized_motors(arm), kp=40.0, kd=4.0)
    spec = rmt.DriveSpec.of(drive)
    assert dict(spec.locked) == arm.locked_joints and spec.urdf.lstrip().startswith("<")
    json.dumps([spec.urdf, spec.motors, spec.kp])  # plain data
    rebuilt = rmt.cached_drive(spec)
    assert rmt.cached_drive(spec) is rebuilt  # once per process
    assert rmt.model_digest(rebuilt.model) == rmt.model_digest(drive.model)
    rng = np.random.default_rng(1)
    Q0 = rng.uniform(arm.lower_limits, arm.upper_limits, (6, arm.nq)) * 0.5
    Q1 = Q0 + rng.uniform(-0.3, 0.3, Q0.shape)
    a = edge_outcomes(drive, Q0, Q1, 0.5, 0.01)
    b = rmt.outcomes_task(spec, Q0, Q1, np.full(6, 0.5), 0.01)
    assert np.array_equal(a.energy, b.energy) and np.array_equal(a.peak_torque, b.peak_torque)


def test_cluster_energies_equal_in_process(scene, client):
    drive, checker, ref = scene
    cost = EnergyCost(drive, OPTIONS.dt, executor=client, chunk_size=128)
    got = build_roadmap(cost, checker, START, GOAL, OPTIONS, show_progress=False)
    _same_roadmap(got, ref)
    assert cost.compute_record() == {"scheduler": client.scheduler.address, "workers": 2,
                                     "chunk_size": 128}
    with cf.ThreadPoolExecutor(2) as pool:  # any concurrent.futures.Executor
        got = build_roadmap(EnergyCost(drive, OPTIONS.dt, executor=pool, chunk_size=300),
                            checker, START, GOAL, OPTIONS, show_progress=False)
    _same_roadmap(got, ref)


def test_killed_worker_is_survived(scene, client, monkeypatch):
    """One worker process is killed (SIGKILL) after a few chunks: its chunks run elsewhere,
    the nanny restarts it, and every energy equals the in-process one."""
    drive, checker, ref = scene
    pids = client.run(os.getpid)
    victim = sorted(pids)[0]
    real = _CountingBar
    killed = []

    class Bar(real):
        def __init__(self, *args, **kw):
            super().__init__(*args, **kw)
            self.label = kw.get("desc")

        def update(self, n=1):
            super().update(n)
            if self.label == "edge energies" and not killed and self.n >= 3 * 25:
                os.kill(pids[victim], signal.SIGKILL)
                killed.append(self.n)

    monkeypatch.setattr(rmod, "_tqdm", lambda show: Bar)
    cost = EnergyCost(drive, OPTIONS.dt, executor=client, chunk_size=25)
    got = build_roadmap(cost, checker, START, GOAL, OPTIONS, show_progress=False)
    assert killed and killed[0] < ref.num_edges + sum(ref.edge_counts.values())
    _same_roadmap(got, ref)
    client.wait_for_workers(2, timeout=60)
    assert set(client.run(os.getpid).values()) != set(pids.values())  # a new process




def _interrupting_bar(after: int):
    real = _CountingBar

    class Bar(real):
        def __init__(self, *args, **kw):
            super().__init__(*args, **kw)
            self.label = kw.get("desc")

        def update(self, n=1):
            super().update(n)
            if self.label == "edge energies" and self.n >= after:
                raise KeyboardInterrupt

    return Bar


def test_interrupted_build_resumes_to_the_same_file(scene, client, tmp_path, monkeypatch):
    """Ctrl-C from the progress callback during a cluster build: finished chunks are in
    <cache>.partial/, no cache file; the rerun (in-process) reuses them and writes a file
    equal to an uninterrupted build's, array for array and checksum."""
    drive, checker, ref = scene
    cache = tmp_path / "rm.npz"
    monkeypatch.setattr(rmod, "_tqdm", lambda show: _interrupting_bar(200))
    with pytest.raises(KeyboardInterrupt):
        build_roadmap(EnergyCost(drive, OPTIONS.dt, executor=client, chunk_size=50),
                      checker, START, GOAL, OPTIONS, cache=cache, show_progress=False)
    monkeypatch.undo()
    assert not cache.exists()
    saved = sorted(rs.partial_dir(cache).glob("chunk-*.npz"))
    assert len(saved) >= 4
    for f in saved:  # a partial file is never taken for a roadmap
        with pytest.raises(ValueError, match="not a mpd_pin roadmap"):
            Roadmap.load(f)
    calls = []
    cost = EnergyCost(drive, OPTIONS.dt, chunk_size=50)
    real_run = rmt.run_chunks

    def counting(*args, **kw):
        for rows, res in real_run(*args, **kw):
            calls.append(rows.size)
            yield rows, res

    monkeypatch.setattr("mpd_pin.dynamics.cost.run_chunks", counting)
    resumed = build_roadmap(cost, checker, START, GOAL, OPTIONS, cache=cache,
                            show_progress=False)
    assert resumed.chunks_reused == len(saved)
    total = ref.num_edges + ref.edge_counts["refused_effort"] + ref.edge_counts["refused_arrival"]
    assert sum(calls) == total - 50 * len(saved)  # reused rows were not simulated again
    assert not rs.partial_dir(cache).exists()
    _same_roadmap(resumed, ref)
    plain = ref.save(tmp_path / "plain.npz")
    with np.load(cache) as a, np.load(plain) as b:
        assert sorted(a.files) == sorted(b.files)
        for name in a.files:
            assert np.array_equal(a[name], b[name]), name
    loaded = build_roadmap(cost, checker, START, GOAL, OPTIONS, cache=cache, show_progress=False)
    assert loaded.chunks_reused == 0
    _same_roadmap(loaded, ref)


def test_partial_chunks_of_another_build_are_not_reused(scene, tmp_path):
    drive, checker, ref = scene
    cache = tmp_path / "rm.npz"
    Q0, Q1, T = ref.nodes[ref.src], ref.nodes[ref.dst], ref.durations
    res = edge_outcomes(drive, Q0[:5], Q1[:5], T[:5], OPTIONS.dt)
    rs.PartialCosts(cache, "another key", Q0, Q1, T).add(np.arange(5), res)
    bad = rs.partial_dir(cache) / "chunk-garbage.npz"
    bad.write_bytes(b"PK\x03\x04 truncated")
    part = rs.PartialCosts(cache, ref.key, Q0, Q1, T)
    assert part.load() is None and part.chunks_reused == 0
    assert not list(rs.partial_dir(cache).glob("chunk-[0-9a-f]*.npz"))  # stale one deleted


def test_atomic_save_leaves_no_partial_file(scene, tmp_path, monkeypatch):
    """A save that fails half-way leaves the previous file intact and no temporary file."""
    _, _, ref = scene
    path = ref.save(tmp_path / "rm.npz")
    before = path.read_bytes()
    real = np.savez_compressed

    def failing(fh, **arrays):
        real(fh, **{k: arrays[k] for k in list(arrays)[:2]})  # some bytes are written …
        raise OSError(28, "No space left on device")  # … then the disk is full

    monkeypatch.setattr(rs.np, "savez_compressed", failing)
    with pytest.raises(OSError, match="No space"):
        ref.save(path)
    with pytest.raises(OSError):
        ref.save(tmp_path / "new.npz")
    monkeypatch.undo()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rm.npz"]
    assert path.read_bytes() == before
    _same_roadmap(Roadmap.load(path, expected_key=ref.key), ref)


SCENARIO = """
name = "tiny"
[arm]
builtin = "planar_3link"
[motor]
preset = "paper"
gear_ratio = 5.0
[roadmap]
num_nodes = 40
k = 6
seed = 2
duration_rule = "distance"
dt = 0.01
[[obstacles]]
type = "box"
center = [0.0, 0.9]
width = 0.3
height = 0.4
[task]
start = [0.6, 0.3, 0.2]
goal = [2.4, -0.3, -0.2]
"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_unreachable_scheduler_exits_2_with_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(rmt, "CONNECT_TIMEOUT", 1.0)
    scn = tmp_path / "tiny.toml"
    scn.write_text(SCENARIO)
    addr = f"tcp://127.0.0.1:{_free_port()}"
    out = tmp_path / "out"
    assert main(["run", str(scn), "--out", str(out), "--quiet", "--scheduler", addr]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and addr in err and "cannot reach" in err, err
    assert not out.exists()  # before any work
    assert main(["run", str(scn), "--out", str(out), "--scheduler", "local:x"]) == 2
    assert "--scheduler 'local:x'" in capsys.readouterr().err
    assert main(["run", "env1", "--out", str(out), "--scheduler", "local:2"]) == 2
    assert "--scheduler applies to energy scenarios" in capsys.readouterr().err
    scn.write_text(SCENARIO + '[compute]\nscheduler = "nowhere"\n')
    assert main(["run", str(scn), "--out", str(out), "--quiet"]) == 2
    assert "compute.scheduler 'nowhere'" in capsys.readouterr().err


def test_cli_local_cluster_end_to_end(tmp_path, capsys):
    """``--scheduler local:2`` and ``[compute] scheduler`` give the in-process result."""
    scn = tmp_path / "tiny.toml"
    scn.write_text(SCENARIO)
    runs = {}
    for label, extra in (("threads", []), ("local", ["--scheduler", "local:2"])):
        out = tmp_path / label
        assert main(["run", str(scn), "--out", str(out), "--quiet", "--no-replay", *extra]) == 0
        runs[label] = json.loads((out / "result.json").read_text())
    capsys.readouterr()
    a, b = runs["threads"], runs["local"]
    assert a["compute"] == {"scheduler": "threads", "workers": 1,
                            "chunk_size": rmt.IN_PROCESS_CHUNK_SIZE}
    assert b["compute"] == {"scheduler": "local:2", "workers": 2,
                            "chunk_size": rmt.DEFAULT_CHUNK_SIZE}
    assert a["roadmap"]["key"] == b["roadmap"]["key"] and b["roadmap"]["chunks_reused"] == 0
    assert a["total_energy"] == b["total_energy"] and a["path"] == b["path"]
    assert a["energy_per_joint"] == b["energy_per_joint"]


def test_cli_says_how_many_chunks_it_reused(tmp_path, capsys, monkeypatch):
    """A build killed after some chunks (here: an exception from the progress bar) is
    resumed by the same command; the summary line and result.json say how many chunks."""
    scn = tmp_path / "tiny.toml"
    scn.write_text(SCENARIO.replace("num_nodes = 40", "num_nodes = 60"))
    cache, out = tmp_path / "rm.npz", tmp_path / "out"
    monkeypatch.setattr("mpd_pin.dynamics.cost.IN_PROCESS_CHUNK_SIZE", 64)
    monkeypatch.setattr(rmod, "_tqdm", lambda show: _interrupting_bar(2 * 64))
    args = ["run", str(scn), "--out", str(out), "--no-replay", "--cache", str(cache),
            "--evaluation", "eager"]  # an eager build (lazy runs simulate a few edges)
    assert main(args) == 130
    assert "interrupted" in capsys.readouterr().err
    saved = len(list(rs.partial_dir(cache).glob("chunk-*.npz")))
    assert saved >= 2 and not cache.exists()
    monkeypatch.setattr(rmod, "_tqdm", lambda show: _CountingBar)
    assert main([*args, "--quiet"]) == 0
    line = capsys.readouterr().out
    assert f"resumed: {saved} chunks of edge energies reused" in line, line
    assert json.loads((out / "result.json").read_text())["roadmap"]["chunks_reused"] == saved
    assert not rs.partial_dir(cache).exists()


def test_open_compute_forms():
    assert rmt.parse_scheduler(None) == ("threads", None)
    assert rmt.parse_scheduler("local:3") == ("local", 3)
    assert rmt.parse_scheduler("tcp://10.0.0.1:8786") == ("address", "tcp://10.0.0.1:8786")
    for bad in ("local:0", "local:-1", "cluster"):
        with pytest.raises(rmt.ComputeError):
            rmt.parse_scheduler(bad)
    assert rmt.open_compute(None).record(256) == {"scheduler": "threads", "workers": 1,
                                                  "chunk_size": 256}
    with pytest.raises(ValueError, match="chunk_size"):
        EnergyCost(mp.Drive(mp.builtin_arm("planar_2link"), mp.SERVO_MOTOR, 1.0, 0.1),
                   chunk_size=0)

