"""Batched τ and τ̇ (``rnea_with_derivative``) against Pinocchio's batched and looped calls.

Prints, measured in this run, for the Panda (fingers locked) and the planar
3-link arm on a batch of K edges × (2N+1) points along quintic references
(default 1000 × 401 = 401 000 configurations):

* seconds per configuration of ``mpd_pin.dynamics.batch.rnea_with_derivative``
  (τ and τ̇; with preallocated outputs, allocating them, with 2 threads, and
  per chunk size for the Panda),
* of ``pin.rneaInParallel`` and ``pin.abaInParallel`` (τ only / q̈ only, 2 threads),
* of a Python loop over ``pin.computeRNEADerivatives`` forming τ̇ (on a subset),
* one edge (401 points) at a time: the reusable ``BatchRneaDerivative`` vs the loop,
* the ratios, and the 1 µs/configuration target for the Panda.

The machine may be shared: every figure is the best of ``--repeats`` runs and
the load average is printed.  Also checks Pinocchio's batch pitfalls (array
order of rneaInParallel outputs).

Usage: python bench/batch_dynamics.py [--edges 1000] [--points 401] [--repeats 5]
"""

from __future__ import annotations

import argparse
import os

import numpy as np
import pinocchio as pin

import mpd_pin as mp
from common import best_of
from mpd_pin.dynamics.batch import DEFAULT_CHUNK, BatchRneaDerivative, rnea_with_derivative

THREADS = 2


def models():
    yield "panda", mp.Arm.from_example_robot_data("panda").model
    yield "planar_3link", mp.builtin_arm("planar_3link").model


def quintic_batch(model: pin.Model, edges: int, points: int, seed: int = 0):
    """q, q̇, q̈, q⃛ along `edges` random quintic rest-to-rest references (T = 1 s)."""
    rng = np.random.default_rng(seed)
    lo = np.maximum(model.lowerPositionLimit, -np.pi)
    hi = np.minimum(model.upperPositionLimit, np.pi)
    q0 = rng.uniform(lo, hi, (edges, model.nq))
    q1 = rng.uniform(lo, hi, (edges, model.nq))
    s, sd, sdd, sddd = mp.quintic(np.linspace(0.0, 1.0, points), 1.0)
    dq = (q1 - q0).T[:, :, None]  # (nv, K, 1)
    shape = (model.nv, edges * points)
    Q = (q0.T[:, :, None] + dq * s).reshape(shape)
    return Q, (dq * sd).reshape(shape), (dq * sdd).reshape(shape), (dq * sddd).reshape(shape)


def loop_rnea_derivatives(model, Q, V, A, J) -> np.ndarray:
    data = model.createData()
    out = np.empty_like(Q)
    for k in range(Q.shape[1]):
        q, v, a = Q[:, k], V[:, k], A[:, k]
        pin.computeRNEADerivatives(model, data, q, v, a)
        m = np.triu(data.M) + np.triu(data.M, 1).T
        out[:, k] = data.dtau_dq @ v + data.dtau_dv @ a + m @ J[:, k]
    return out


def order_pitfall(model: pin.Model) -> str:
    """Does rneaInParallel write correctly into C-ordered / strided outputs?"""
    rng = np.random.default_rng(5)
    n = 37
    Q, V, A = (rng.normal(size=(model.nv, n)) for _ in range(3))
    data = model.createData()
    ref = np.stack([pin.rnea(model, data, Q[:, k], V[:, k], A[:, k]) for k in range(n)], 1)
    pool = pin.ModelPool(model, THREADS)
    report = []
    outs = {
        "F-order out": np.zeros((model.nv, n), order="F"),
        "C-order out": np.zeros((model.nv, n), order="C"),
        "strided out": np.zeros((model.nv, 2 * n))[:, ::2],
    }
    for label, out in outs.items():
        pin.rneaInParallel(THREADS, pool, Q, V, A, out)
        ok = np.allclose(out, ref, rtol=1e-12, atol=1e-12)
        report.append(f"{label}: {'correct' if ok else 'WRONG (silently)'}")
    return "; ".join(report)


def measure(name: str, model: pin.Model, args) -> None:
    batch = args.edges * args.points
    us = 1e6
    Q, V, A, J = quintic_batch(model, args.edges, args.points)
    Qf, Vf, Af = (np.asfortranarray(x) for x in (Q, V, A))
    out = (np.empty_like(Q), np.empty_like(Q))
    rnea_with_derivative(model, Q[:, :1000], V[:, :1000], A[:, :1000], J[:, :1000])

    def ours_out():
        rnea_with_derivative(model, Q, V, A, J, chunk=args.chunk, out=out)

    def ours_alloc():
        rnea_with_derivative(model, Q, V, A, J, chunk=args.chunk)

    def ours_threads():
        rnea_with_derivative(model, Q, V, A, J, chunk=args.chunk, threads=THREADS, out=out)

    edge = BatchRneaDerivative(model, chunk=args.chunk)
    one = slice(0, args.points)

    def ours_edge():
        edge(Q[:, one], V[:, one], A[:, one], J[:, one])

    pool = pin.ModelPool(model, THREADS)
    tau_f = np.zeros_like(Qf, order="F")
    acc_f = np.zeros_like(Qf, order="F")

    def rnea_par():
        pin.rneaInParallel(THREADS, pool, Qf, Vf, Af, tau_f)

    def aba_par():
        pin.abaInParallel(THREADS, pool, Qf, Vf, tau_f, acc_f)

    n_loop = min(args.loop, batch)
    sl = slice(0, n_loop)

    def loop():
        loop_rnea_derivatives(model, Q[:, sl], V[:, sl], A[:, sl], J[:, sl])

    t_ours = best_of(ours_out, args.repeats)[0] / batch
    t_alloc = best_of(ours_alloc, args.repeats)[0] / batch
    t_threads = best_of(ours_threads, args.repeats)[0] / batch
    t_edge = best_of(ours_edge, 20 * args.repeats)[0] / args.points
    t_rnea = best_of(rnea_par, args.repeats)[0] / batch
    t_aba = best_of(aba_par, args.repeats)[0] / batch
    t_loop = best_of(loop, max(1, args.repeats // 2))[0] / n_loop
    # consistency: the same τ as rneaInParallel, the same τ̇ as the loop
    rnea_par()
    err_tau = np.abs(out[0] - tau_f).max() / np.abs(tau_f).max()
    ref_dot = loop_rnea_derivatives(model, Q[:, :500], V[:, :500], A[:, :500], J[:, :500])
    err_dot = np.abs(out[1][:, :500] - ref_dot).max() / np.abs(ref_dot).max()
    print(f"\n{name} (nv = {model.nv})")
    print(f"  rnea_with_derivative (tau, tau_dot), out=   {t_ours * us:8.3f} us/config")
    print(f"  rnea_with_derivative, allocating outputs    {t_alloc * us:8.3f} us/config")
    print(f"  rnea_with_derivative, threads={THREADS}, out=      {t_threads * us:8.3f} us/config")
    print(
        f"  one edge ({args.points} points), BatchRneaDerivative  {t_edge * us:8.3f} us/config "
        f"(loop/this = {t_loop / t_edge:.1f})"
    )
    print(f"  pin.rneaInParallel ({THREADS} threads, tau)      {t_rnea * us:8.3f} us/config")
    print(f"  pin.abaInParallel ({THREADS} threads, qdd)       {t_aba * us:8.3f} us/config")
    print(
        f"  loop computeRNEADerivatives -> tau_dot      {t_loop * us:8.3f} us/config "
        f"({n_loop} configs)"
    )
    print(
        f"  ratios: ours/rneaInParallel = {t_ours / t_rnea:.2f}, "
        f"ours/abaInParallel = {t_ours / t_aba:.2f}, loop/ours = {t_loop / t_ours:.1f}"
    )
    print(f"  max rel. difference: tau {err_tau:.1e}, tau_dot {err_dot:.1e}")
    if name == "panda":
        verdict = "met" if t_ours <= 1e-6 else "NOT met"
        print(f"  target <= 1 us/config for the Panda (1 thread): {verdict}")
        sweep = []
        for chunk in (256, 512, 1024, 2048, 4096, 8192):

            def run(chunk=chunk):
                rnea_with_derivative(model, Q, V, A, J, chunk=chunk, out=out)

            sweep.append(f"{chunk}: {best_of(run, args.repeats)[0] / batch * us:.3f}")
        print(f"  chunk sweep (us/config): {', '.join(sweep)}")
        print(f"  pitfall check, rneaInParallel outputs: {order_pitfall(model)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--edges", type=int, default=1000)
    ap.add_argument("--points", type=int, default=401, help="2N+1 points per edge")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--loop", type=int, default=20000, help="configs for the Python loop")
    ap.add_argument("--chunk", type=int, default=DEFAULT_CHUNK)
    args = ap.parse_args()
    batch = args.edges * args.points
    print(
        f"batch = {args.edges} x {args.points} = {batch} configurations, chunk = {args.chunk}, "
        f"cpus = {os.cpu_count()}, load average at start = {os.getloadavg()[0]:.2f}"
    )
    for name, model in models():
        measure(name, model, args)
    print(f"\nload average at end = {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
