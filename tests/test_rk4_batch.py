"""The batched RK4 gives the very same numbers as before its fixed cost was cut (issue 24).

``tests/data/rk4_reference.npz`` holds the five :class:`~mpd_pin.EdgeOutcomes` arrays of
the edge sets below, computed by the integrator as it was before the rewrite (main at
31cacae), and SHA-256 digests of the recorded time series (``record=True``, the path of
:mod:`mpd_pin.motion.series`). It was written once with

    PYTHONPATH=<a checkout of that commit> python tests/test_rk4_batch.py --write

and these tests compare the current code against it with ``np.array_equal``: the edge
energies of the paper must not change by a single bit. The sets cover the sized Panda
(stiff currents, 24 V saturation, four step counts in one batch), paper 000's case 1
(classical RK4, feed-forward), a 3-link drive that mixes stiff and classical joints
without feed-forward, and a Panda with classical currents and saturation.

Bit identity is a property of one machine and library build (BLAS kernels, numpy's SIMD
``exp``, Pinocchio's ABA): where the fingerprint stored with the fixture differs from
this one, the outcomes are compared to 1e-9 of each field's physical scale instead, and
the recorded series are checked against this machine's own non-recording integrator,
bit for bit. Rounding differences scale with the magnitudes the integrator carries, not
with a result that nearly cancels: an end velocity of 1e-9 rad/s is the residue of
velocities of order 1 rad/s, so its tolerance is 1e-9 of the moves' speed, not of itself.
"""

from __future__ import annotations

import copy
import functools
import hashlib
import platform
import sys
from concurrent.futures import ThreadPoolExecutor
from dataclasses import fields
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import mpd_pin as mp
from mpd_pin.dynamics.current import current_step
from mpd_pin.dynamics.remote import model_digest
from mpd_pin.dynamics.simulate import EdgeOutcomes, edge_outcomes, integrate_batch, step_count

FIXTURE = Path(__file__).resolve().parent / "data" / "rk4_reference.npz"
FIELDS = ("energy", "net_energy", "end_error", "end_velocity", "peak_torque")
DT = 5e-3


@functools.cache
def _arm(name: str) -> mp.Arm:
    if name == "panda":
        return mp.Arm.from_example_robot_data("panda")
    return mp.builtin_arm(name)


def _drive(case: str) -> mp.Drive:
    """The drives of the edge sets (gains as in the scenarios that use them)."""
    if case == "panda-sized":  # scenarios with `preset = "sized"`: stiff, 24 V
        arm = _arm("panda")
        return mp.Drive(arm, mp.sized_motors(arm), kp=20.0, kd=1.0)
    if case == "case1":  # mpd_pin/scenarios/case1.toml
        return mp.Drive(_arm("planar_3link"), mp.PAPER_MOTOR.with_gear_ratio(9.0), kp=40.0,
                        kd=4.0)
    if case == "3link-mixed-pd":  # joint 0 stiff, joint 1 classical, joint 2 stiff and 6 V
        servo6 = mp.DCMotor(**{**mp.SERVO_MOTOR.__dict__, "v_max": 6.0})
        return mp.Drive(_arm("planar_3link"),
                        [mp.SERVO_MOTOR, mp.PAPER_MOTOR.with_gear_ratio(5.0), servo6],
                        kp=[200.0, 40.0, 200.0], kd=[10.0, 4.0, 10.0], feedforward=False)
    if case == "panda-classical-12V":  # L/R = 10 ms: classical RK4 on the currents
        motor = mp.DCMotor(R=1.0, L=0.01, Kt=0.1, Ke=0.1, B=1e-4, J=1e-4, gear_ratio=50.0,
                           v_max=12.0)
        return mp.Drive(_arm("panda"), motor, kp=20.0, kd=1.0)
    raise KeyError(case)


#: case → (number of edges, spread of the moves (rad), durations to cycle through (s), seed)
CASES = {
    "panda-sized": (40, 0.5, (0.5, 0.75, 1.0, 1.5), 11),
    "case1": (20, 0.6, (1.0, 1.25), 12),
    "3link-mixed-pd": (8, 0.5, (0.5, 1.0), 13),
    "panda-classical-12V": (8, 0.5, (0.5, 1.0), 14),
}


def _edges(drive: mp.Drive, case: str):
    k, spread, durations, seed = CASES[case]
    arm = drive.arm
    rng = np.random.default_rng(seed)
    lo, hi = arm.lower_limits, arm.upper_limits
    mid, half = (lo + hi) / 2, (hi - lo) / 2
    Q0 = mid + half * rng.uniform(-0.7, 0.7, (k, arm.nq))
    Q1 = np.clip(Q0 + rng.normal(0.0, spread, (k, arm.nq)), lo, hi)
    T = np.resize(np.asarray(durations, dtype=float), k)
    return Q0, Q1, T


def _record(drive: mp.Drive, Q0, Q1, T):
    N = np.array([step_count(x, DT) for x in T.tolist()], dtype=np.int64)
    return integrate_batch(drive, Q0, Q1, T, N, DT, 2, record=True)


def _series_digests(drive: mp.Drive, Q0, Q1, T) -> list[str]:
    """SHA-256 of each recorded series (q, v, i, V, E⁺(t), E(t)) and of the outcomes."""
    outcomes, rec = _record(drive, Q0, Q1, T)
    # the five outcomes the fixture's code had (the bus energies came later, §3i)
    arrays = [*outcomes[:5], rec.q, rec.v, rec.i, rec.V, rec.energy_t, rec.net_energy_t]
    return [_digest(a) for a in arrays]


def _digest(a: np.ndarray) -> str:
    """The first 16 hex digits of the SHA-256 of an array's bytes."""
    return hashlib.sha256(np.ascontiguousarray(a, dtype=float).tobytes()).hexdigest()[:16]


def fingerprint() -> str:
    """What bit identity depends on besides the code: library versions, machine, models."""
    try:
        from numpy._core._multiarray_umath import __cpu_features__ as cpu
    except ImportError:  # pragma: no cover - older numpy
        cpu = {}
    parts = [np.__version__, pin.__version__, platform.machine(),
             ",".join(sorted(k for k, v in cpu.items() if v)),
             model_digest(_arm("panda").model), model_digest(_arm("planar_3link").model)]
    return hashlib.sha256("|".join(parts).encode()).hexdigest()


def compute() -> dict[str, np.ndarray]:
    """Every array the fixture holds, computed by the code on ``sys.path``."""
    out: dict[str, np.ndarray] = {"fingerprint": np.array(fingerprint())}
    for case in CASES:
        drive = _drive(case)
        Q0, Q1, T = _edges(drive, case)
        res = edge_outcomes(drive, Q0, Q1, T, DT)
        out[f"{case}/inputs_sha256"] = np.array(_digest(np.concatenate([Q0, Q1], axis=1)))
        out[f"{case}/T"] = T
        _, rec = _record(drive, Q0, Q1, T)  # does any joint reach its supply limit?
        out[f"{case}/saturates"] = np.array(bool(np.any(np.abs(rec.V) >= drive.v_max)))
        for name in FIELDS:
            out[f"{case}/{name}"] = getattr(res, name)
        sel = np.arange(0, len(T), max(1, len(T) // 4))[:4]  # a few edges, all step counts
        out[f"{case}/series_rows"] = sel
        out[f"{case}/series_sha256"] = np.array(_series_digests(drive, Q0[sel], Q1[sel], T[sel]),
                                                dtype="S16")
    return out


# ----------------------------------------------------------------------------- tests
@pytest.fixture(scope="module")
def reference():
    with np.load(FIXTURE) as data:
        ref = {k: data[k] for k in data.files}
    return ref, str(ref["fingerprint"]) == fingerprint()


def _scale(case: str, name: str, want: np.ndarray) -> float:
    """The physical scale of a field of ``case``: the moves' size (rad) for the end error,
    their mean speed (rad/s) for the end velocity, the field's own largest value else."""
    Q0, Q1, T = _edges(_drive(case), case)
    if name == "end_error":
        return float(np.abs(Q1 - Q0).max())
    if name == "end_velocity":
        return float((np.abs(Q1 - Q0) / T[:, None]).max())
    return float(np.abs(want).max())


def _compare(got: np.ndarray, want: np.ndarray, exact: bool, case: str, name: str,
             what: str = "") -> None:
    """Bit identity on the fixture's machine, else 1e-9 of the field's physical scale."""
    what = f"{what or case} {name}"
    if exact:
        assert got.shape == want.shape and np.array_equal(got, want), (
            f"{what}: not bit-identical to the reference, max |diff| "
            f"{np.max(np.abs(got - want)):.3g}")
    else:
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9 * _scale(case, name, want),
                                   err_msg=f"{what} (other machine or library build)")


@pytest.mark.parametrize("case", sorted(CASES))
def test_outcomes_bit_identical(reference, case):
    ref, exact = reference
    drive = _drive(case)
    Q0, Q1, T = _edges(drive, case)
    assert _digest(np.concatenate([Q0, Q1], axis=1)) == str(ref[f"{case}/inputs_sha256"])
    assert np.array_equal(T, ref[f"{case}/T"])
    res = edge_outcomes(drive, Q0, Q1, T, DT)
    for name in FIELDS:
        _compare(getattr(res, name), ref[f"{case}/{name}"], exact, case, name)
    assert np.all(np.isfinite(res.energy)) and np.all(res.energy >= 0)
    # one edge per batch and odd chunks: the same rows (rows never mix, whatever the batch)
    small = edge_outcomes(drive, Q0[:5], Q1[:5], T[:5], DT, chunk=2, threads=1)
    for name in FIELDS:
        _compare(getattr(small, name), ref[f"{case}/{name}"][:5], exact, case, name)


@pytest.mark.parametrize("case", sorted(CASES))
def test_recorded_series_bit_identical(reference, case):
    """The recording path (``record=True``) integrates the very same numbers as the edge
    energies: bit for bit against its own non-recording run, and against the fixture's
    digests on the fixture's machine."""
    ref, exact = reference
    drive = _drive(case)
    Q0, Q1, T = _edges(drive, case)
    sel = ref[f"{case}/series_rows"]
    outcomes, rec = _record(drive, Q0[sel], Q1[sel], T[sel])
    plain = edge_outcomes(drive, Q0[sel], Q1[sel], T[sel], DT)
    for k, name in enumerate(FIELDS):
        assert np.array_equal(outcomes[k], getattr(plain, name)), name
    steps = [step_count(x, DT) for x in T[sel].tolist()]
    for k, n in enumerate(steps):  # each row's series ends where its outcomes say
        assert np.array_equal(rec.energy_t[n, k], outcomes[0][k])
        assert np.array_equal(rec.q[n, k] - Q1[sel][k], outcomes[2][k])
    if exact:
        want = [d.decode() for d in ref[f"{case}/series_sha256"].tolist()]
        assert _series_digests(drive, Q0[sel], Q1[sel], T[sel]) == want


def test_copies_and_threads_share_no_buffers(reference):
    """What is kept per drive (ModelPool, RNEA plans, constants) is neither carried into a
    deep copy nor shared by concurrent batches: both give the very same numbers."""
    ref, exact = reference
    drive = _drive("case1")
    Q0, Q1, T = _edges(drive, "case1")
    edge_outcomes(drive, Q0[:2], Q1[:2], T[:2], DT)  # fill the caches
    twin = copy.deepcopy(drive)
    res = edge_outcomes(twin, Q0, Q1, T, DT)
    for name in FIELDS:
        _compare(getattr(res, name), ref[f"case1/{name}"], exact, "case1", name, "deep copy")
    rows = [slice(k, k + 5) for k in range(0, 20, 5)]
    with ThreadPoolExecutor(4) as pool:
        parts = list(pool.map(lambda r: edge_outcomes(drive, Q0[r], Q1[r], T[r], DT), rows))
    for r, part in zip(rows, parts, strict=True):
        for name in FIELDS:
            _compare(getattr(part, name), ref[f"case1/{name}"][r], exact, "case1", name, "threads")


def test_fixture_covers_the_branches(reference):
    """Saturation, stiff and classical currents, several step counts per batch."""
    ref, _ = reference
    assert len(set(ref["panda-sized/T"].tolist())) == 4 and ref["panda-sized/T"].size >= 40
    assert ref["case1/T"].size >= 20
    for case, stiff in (("panda-sized", [True] * 7), ("case1", [False] * 3),
                        ("3link-mixed-pd", [True, False, True]),
                        ("panda-classical-12V", [False] * 7)):
        cs = current_step(_drive(case), DT)
        assert cs.stiff.tolist() == stiff, case
    assert [bool(ref[f"{c}/saturates"]) for c in sorted(CASES)] == [True, False, True, True]
    # the fixture holds the outcomes of its time, every field but the bus energies (§3i)
    assert [f.name for f in fields(EdgeOutcomes)] == [*FIELDS, "bus_energy"]
    assert all(ref[f"case1/{f}"].shape == ref["case1/energy"].shape for f in FIELDS)


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python tests/test_rk4_batch.py --write   (writes " + str(FIXTURE) + ")")
    FIXTURE.parent.mkdir(exist_ok=True)
    np.savez_compressed(FIXTURE, **compute())
    print(f"wrote {FIXTURE} ({FIXTURE.stat().st_size} bytes) with mpd_pin from "
          f"{Path(mp.__file__).parent}")
