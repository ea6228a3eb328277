"""Cycles: legs with payloads and dwells, and one cycle time shared between them
(docs/design.md §8b, issue 33).

A cycle is a sequence of :class:`Leg`: from ``start``, each leg moves to its ``goal``
(rad) carrying its ``payload`` (a :class:`~mpd_pin.Payload`, or nothing), then waits
``dwell`` seconds there. :meth:`mpd_pin.EnergyPlanner.plan_cycle` plans it
(:func:`plan_cycle`) on one roadmap (docs/design.md §4i: the nodes shared by every leg,
edges and energies per payload) and returns a :class:`Cycle`.

**Dwell.** The dwell after a leg holds that leg's goal with **that leg's payload**: the
arm arrives carrying what the leg carried, and grasps (or releases) at the end of the
dwell, so ``Leg(goal=pick, dwell=0.5)`` waits unloaded at the pick pose and
``Leg(goal=place, payload=part, dwell=0.3)`` waits loaded at the place pose. At rest the
controller holds the pose with the holding current i = G(q)/(n Kt) (G with the payload's
gravity when the leg carries it), whose only loss is copper: the dwell draws
Σ_j R_j i_j² × dwell (J) from the supply (every joint's power is ≥ 0 at rest, so a shared
bus draws the same).

**Time allocation** (``cycle_time`` given). Each leg k has an energy–time front E_k(T)
(docs/design.md §9d): it is first planned with ``max_duration`` = the time left for motion
(cycle_time − Σ dwell), which gives its fastest motion f_k and the fronts of every
candidate and execution it priced. The allocation minimises Σ_k Ê_k(T_k) subject to
Σ_k T_k + Σ dwell ≤ cycle_time and T_k ≥ f_k, where Ê_k(T) is what a plan capped at T can
return: the least energy over the candidates' fronts at durations ≤ T (a stop-and-go motion
is its one point; a non-stop front is its perfect-tracking screen calibrated by the
durations simulated on it: screen × the simulated/screen ratio, interpolated in T).
Ê_k is non-increasing but not convex in general (a running minimum of several candidates'
curves, with steps where one becomes feasible; on the Panda E(T) rises with T past its
minimum, so Ê_k is flat there), so equal marginal energy (bisection on λ) would only be
exact on its lower convex hull, whose points between hull vertices are no motion of the
leg. The allocation is therefore a **dynamic programme over a grid** of the slack
S = cycle_time − Σ dwell − Σ f_k in :data:`GRID_STEPS` steps: T_k = f_k + j_k S/N with
Σ j_k ≤ N, exact on the grid for any front shape, O(K N²) (a few ms). Each leg is then
planned with ``max_duration`` = T_k, leg after leg, and the legs not yet planned are
allocated again on the time actually left (a leg that needs less than its cap passes the
rest on). The first plan is kept when its motion already fits within T_k (it is the best
over a range containing [f_k, T_k]). Without ``cycle_time`` each leg follows its own
duration rule (docs/design.md §9c; the planner's ``max_duration`` caps each leg).

A ``cycle_time`` below Σ f_k + Σ dwell is a planning outcome:
:class:`~mpd_pin.errors.CycleTimeTooShort` (a ``NoMotionWithinDuration``; ``mpd-pin run``
exits with status 3) names that minimum.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..dynamics.payload import Payload
from ..errors import CycleTimeTooShort, NoMotionWithinDuration, NoPathError
from .config import ConfigError
from .legs import CycleSpec, Leg, leg_configuration
from .planned import Plan, check_output_dir, plan_and_save
from .results import to_jsonable, write_json

__all__ = ["Leg", "CycleLeg", "Cycle", "CycleSpec", "plan_cycle", "allocate", "leg_front",
           "dwell_energy", "GRID_STEPS", "DWELL_RULE", "CYCLE_FORMAT"]

#: Grid steps of the slack in the allocation's dynamic programme.
GRID_STEPS = 400

#: What the dwell after a leg holds (cycle.json ``dwell_rule``).
DWELL_RULE = ("the dwell after a leg holds that leg's goal with that leg's payload "
              "(grasp or release at the end of the dwell): holding current i = G(q)/(n Kt), "
              "copper loss sum_j R_j i_j^2 times the dwell")

#: cycle.json ``format``.
CYCLE_FORMAT = "mpd_pin.cycle/1"

#: Seconds kept free of the cycle time, so that floating-point sums of the caps stay
#: within it.
_SLACK_GUARD = 1e-6


@dataclass
class CycleLeg:
    """One planned leg: its :class:`~mpd_pin.Plan`, ``start_time`` (s from the start of the
    cycle), ``duration`` (s, its motion's), ``dwell`` (s) and ``dwell_energy`` (J, holding
    its goal with ``payload``), ``max_duration`` (s: the cap it was planned within, the
    allocation's T_k; None without a cycle time), ``fastest_duration`` (s)."""

    index: int
    name: str
    plan: Plan
    start_time: float
    duration: float
    dwell: float
    payload: Payload | None
    dwell_energy: float
    dwell_energy_per_joint: np.ndarray
    max_duration: float | None = None
    fastest_duration: float | None = None
    replanned: bool = False

    @property
    def energy(self) -> float:
        """The motion's energy (J, drawn from the supply)."""
        return float(self.plan.total_energy)

    @property
    def end_time(self) -> float:
        """When the motion ends and the dwell begins (s)."""
        return self.start_time + self.duration

    @property
    def folder(self) -> str:
        """The leg's folder in :meth:`Cycle.save`."""
        return f"leg{self.index}"

    def record(self) -> dict[str, Any]:
        """cycle.json's entry of this leg."""
        p = self.plan
        return {
            "index": self.index,
            "name": self.name,
            "folder": self.folder,
            "start": np.asarray(p.path[0], float).tolist(),
            "goal": np.asarray(p.path[-1], float).tolist(),
            "payload": None if self.payload is None else self.payload.describe(),
            "start_time": self.start_time,
            "duration": self.duration,
            "max_duration": self.max_duration,
            "fastest_duration": self.fastest_duration,
            "replanned": self.replanned,
            "execution": p.motion.execution,
            "total_energy": self.energy,
            "energy_per_joint": np.asarray(p.energy_per_joint, float).tolist(),
            "dwell": self.dwell,
            "dwell_energy": self.dwell_energy,
            "dwell_energy_per_joint": np.asarray(self.dwell_energy_per_joint, float).tolist(),
        }


class Cycle:
    """A planned cycle (module docstring). ``legs``: the :class:`CycleLeg` in order;
    ``cycle_time`` (s or None); ``total_energy`` (J): the legs' motions plus the dwells;
    ``motion_energy``, ``dwell_energy`` (J); ``duration`` (s): Σ leg durations + Σ dwell;
    ``allocation``: how the cycle time was shared (None without one)."""

    def __init__(self, legs: list[CycleLeg], cycle_time: float | None,
                 allocation: dict[str, Any] | None, seconds: dict[str, float],
                 name: str = "cycle") -> None:
        self.legs = legs
        self.cycle_time = cycle_time
        self.allocation = allocation
        self.seconds = seconds
        self.name = name
        self._saved: dict[str, Any] | None = None

    @property
    def motion_energy(self) -> float:
        return float(sum(leg.energy for leg in self.legs))

    @property
    def dwell_energy(self) -> float:
        return float(sum(leg.dwell_energy for leg in self.legs))

    @property
    def total_energy(self) -> float:
        """The energy of the whole cycle (J): every leg's motion and every dwell."""
        return self.motion_energy + self.dwell_energy

    @property
    def duration(self) -> float:
        """Σ leg durations + Σ dwell (s)."""
        return float(sum(leg.duration + leg.dwell for leg in self.legs))

    def __repr__(self) -> str:
        cap = "" if self.cycle_time is None else f" within {self.cycle_time:g} s"
        return (f"Cycle({len(self.legs)} legs: {self.total_energy:.6g} J in "
                f"{self.duration:.3f} s{cap}; dwells {self.dwell_energy:.4g} J)")

    def to_dict(self) -> dict[str, Any]:
        """cycle.json as plain JSON data."""
        return to_jsonable({
            "format": CYCLE_FORMAT,
            "name": self.name,
            "feasible": True,
            "cycle_time": self.cycle_time,
            "duration": self.duration,
            "total_energy": self.total_energy,
            "motion_energy": self.motion_energy,
            "dwell_energy": self.dwell_energy,
            "dwell_rule": DWELL_RULE,
            "legs": [leg.record() for leg in self.legs],
            "allocation": self.allocation,
            "seconds": self.seconds,
            "outputs": None if self._saved is None else self._saved.get("outputs"),
        })

    def power(self) -> dict[str, np.ndarray]:
        """The supply's power over the whole cycle: ``t`` (s) and ``P`` (W), each leg's
        motion from its time series, each dwell its constant holding loss."""
        from ..dynamics.supply import supply_power

        ts, ps = [], []
        for leg in self.legs:
            s = leg.plan.series
            t = np.asarray(s["t"], float) + leg.start_time
            P = supply_power(leg.plan.motion.supply, np.asarray(s["V"]) * np.asarray(s["i"]))
            ts.append(t)
            ps.append(np.asarray(P, float))
            if leg.dwell > 0:
                hold = leg.dwell_energy / leg.dwell
                ts.append(np.array([leg.end_time, leg.end_time + leg.dwell]))
                ps.append(np.array([hold, hold]))
        return {"t": np.concatenate(ts), "P": np.concatenate(ps)}

    def figure(self):
        """cycle.png: the supply's power over the whole cycle (W), the legs and dwells
        shaded, each leg's energy (and each dwell's) written on it."""
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt

        from ..viz.layout import tight

        power = self.power()
        fig, ax = plt.subplots(figsize=(10, 4))
        ax.plot(power["t"], power["P"], color="black", lw=1.0, gid="power")
        top = float(np.max(power["P"])) if power["P"].size else 1.0
        top = top if top > 0 else 1.0
        colors = ("#cfe2f3", "#d9ead3")
        for k, leg in enumerate(self.legs):
            ax.axvspan(leg.start_time, leg.end_time, color=colors[k % 2], alpha=0.8,
                       gid=f"leg:{leg.index}")
            carried = "" if leg.payload is None else f"\n{leg.payload.name} {leg.payload.mass:g} kg"
            ax.text(0.5 * (leg.start_time + leg.end_time), 1.02 * top,
                    f"{leg.name}\n{leg.energy:.3g} J{carried}", ha="center", va="bottom",
                    fontsize=8)
            if leg.dwell > 0:
                ax.axvspan(leg.end_time, leg.end_time + leg.dwell, color="#eeeeee",
                           hatch="//", alpha=0.9, gid=f"dwell:{leg.index}")
                ax.text(leg.end_time + 0.5 * leg.dwell, 0.5 * top,
                        f"dwell\n{leg.dwell_energy:.2g} J", ha="center", va="center",
                        fontsize=7, rotation=90)
        if self.cycle_time is not None:
            ax.axvline(self.cycle_time, color="red", ls="--", lw=1.0, gid="cycle_time")
        ax.set_xlabel("time in the cycle (s)")
        ax.set_ylabel("supply power (W)")
        ax.set_ylim(top=1.35 * top)
        cap = "" if self.cycle_time is None else f", cycle time {self.cycle_time:g} s"
        ax.set_title(f"{self.name}: {self.total_energy:.4g} J in {self.duration:.3f} s{cap} "
                     f"(dwells {self.dwell_energy:.3g} J)", fontsize=10)
        tight(fig)
        return fig

    def save(self, out_dir: str | os.PathLike, *, replay: bool = True,
             plots: bool = True) -> dict[str, Any]:
        """Write one folder per leg (``leg1``, ``leg2``, …: :meth:`mpd_pin.Plan.save`),
        ``cycle.png`` (with ``plots``) and ``cycle.json`` last into ``out_dir``; returns
        cycle.json's content."""
        out_dir = Path(out_dir)
        check_output_dir(out_dir)
        for leg in self.legs:
            leg.plan.save(out_dir / leg.folder, replay=replay, plots=plots)
        if plots:
            import matplotlib.pyplot as plt

            fig = self.figure()
            try:
                fig.savefig(out_dir / "cycle.png", dpi=110)
            finally:
                plt.close(fig)
        self._saved = {"outputs": sorted([p.name for p in out_dir.iterdir()] + ["cycle.json"])}
        doc = self.to_dict()
        write_json(out_dir / "cycle.json", doc)
        return doc


# ----------------------------------------------------------------------------- energy
def dwell_energy(drive, q: Any, dwell: float) -> np.ndarray:
    """E per joint (J) of holding ``q`` (rad) still for ``dwell`` s with ``drive`` (its arm
    carrying the payload, if any): R_j i_j² × dwell with i = G(q)/(n Kt) (A)."""
    i = drive.holding_current(np.asarray(q, float))
    return np.asarray(drive.R * i * i * float(dwell), float)


# ------------------------------------------------------------------------------ fronts
def _curves(record: dict[str, Any]) -> list[tuple[np.ndarray, np.ndarray]]:
    """(T s, E J) points of every feasible front in a plan's ``energy_duration``: a
    stop-and-go motion's one point, a non-stop front's screen calibrated by its simulated
    durations (and those durations themselves)."""
    fronts = []
    for cand in record.get("candidates") or []:
        fronts += [cand.get("nonstop"), cand.get("stop")]
    fronts.append(record.get("returned"))
    out = []
    for f in fronts:
        if not f or not f.get("feasible"):
            continue
        sim = np.array(f.get("simulated") or [], float).reshape(-1, 2)
        screen = np.array(f.get("screen") or [], float).reshape(-1, 2)
        if f.get("execution") != "nonstop" or screen.shape[0] < 2:
            pts = sim if sim.size else np.array([[f["duration"], f["total_energy"]]], float)
        else:
            screen = screen[np.argsort(screen[:, 0], kind="stable")]
            fastest = float(f.get("fastest_duration") or screen[0, 0])
            screen = screen[screen[:, 0] >= fastest - 1e-12]
            if screen.shape[0] < 2:
                pts = sim
            else:
                st, se = screen[:, 0], screen[:, 1]
                inside = sim[(sim[:, 0] >= st[0]) & (sim[:, 0] <= st[-1])] if sim.size else sim
                est = se.copy()
                if inside.size:
                    ref = np.interp(inside[:, 0], st, se)
                    ok = ref > 0
                    if ok.any():
                        order = np.argsort(inside[ok, 0])
                        ratio = inside[ok, 1][order] / ref[ok][order]
                        est = se * np.interp(st, inside[ok, 0][order], ratio)
                pts = np.vstack([np.stack([st, est], axis=1), sim]) if sim.size else \
                    np.stack([st, est], axis=1)
        pts = pts[np.isfinite(pts).all(axis=1)] if pts.size else pts
        if pts.size:
            pts = pts[np.argsort(pts[:, 0], kind="stable")]
            out.append((pts[:, 0], pts[:, 1]))
    return out


def leg_front(plan: Plan) -> tuple[float, Callable[[np.ndarray], np.ndarray]]:
    """(T_min s, Ê) of a planned leg: Ê(T) (J) for an array of durations T (s), the least
    energy a plan capped at T can return according to the fronts of ``plan`` (module
    docstring; ∞ below T_min, the fastest duration any front reaches)."""
    curves = _curves(plan.energy_duration)
    if not curves:  # nothing but the motion itself
        curves = [(np.array([plan.motion.duration]), np.array([plan.total_energy]))]
    t_min = float(min(c[0][0] for c in curves))

    def front(T: np.ndarray) -> np.ndarray:
        T = np.asarray(T, float)
        best = np.full(T.shape, math.inf)
        for t, e in curves:
            inside = (T >= t[0] - 1e-12) & (T <= t[-1] + 1e-12)
            val = np.where(inside, np.interp(T, t, e), math.inf)
            # a cap beyond the front's last point still allows its best point
            val = np.where(T > t[-1], float(np.min(e)), val)
            best = np.minimum(best, val)
        order = np.argsort(T, kind="stable")
        best[order] = np.minimum.accumulate(best[order])  # a cap T allows every t <= T
        return best

    return t_min, front


def allocate(fronts: Sequence[Callable[[np.ndarray], np.ndarray]], fastest: Sequence[float],
             budget: float, steps: int = GRID_STEPS,
             dt: float | None = None) -> tuple[list[float], list[float]]:
    """Durations T_k (s) minimising Σ_k fronts[k](T_k) subject to Σ_k T_k ≤ ``budget`` (s)
    and T_k ≥ ``fastest[k]``: a dynamic programme over at most ``steps`` steps of the slack
    (module docstring); with ``dt`` (s) the step is a whole number of ``dt``, so durations
    on the dt grid stay on it. Returns (T_k, the fronts' energies there, J). ValueError
    when the budget is below Σ fastest."""
    f = np.asarray(fastest, float)
    slack = float(budget) - float(f.sum())
    if slack < -1e-6:
        raise ValueError(f"budget {budget:g} s is below the fastest legs' sum {f.sum():g} s")
    K = f.size
    if K == 0:
        return [], []
    h = slack / steps
    if dt is not None and slack > 0:
        h = dt * math.ceil(slack / (dt * steps) - 1e-9)
        steps = int(math.floor(slack / h + 1e-9))
    if slack <= 0.0 or steps < 1:
        return f.tolist(), [float(fr(np.array([t]))[0]) for fr, t in zip(fronts, f,
                                                                          strict=True)]
    grid = np.arange(steps + 1) * h
    E = [np.asarray(fr(fk + grid), float) for fr, fk in zip(fronts, f, strict=True)]
    V = E[0].copy()
    choices = []
    s = np.arange(steps + 1)[:, None]
    j = np.arange(steps + 1)[None, :]
    valid = j <= s
    for k in range(1, K):
        M = np.where(valid, E[k][np.minimum(j, steps)] + V[np.clip(s - j, 0, steps)], math.inf)
        arg = np.argmin(M, axis=1)
        V = M[np.arange(steps + 1), arg]
        choices.append(arg)
    used = steps  # more time never costs more: a cap only allows more durations
    T = np.zeros(K)
    for k in range(K - 1, 0, -1):
        jk = int(choices[k - 1][used])
        T[k] = f[k] + jk * h
        used -= jk
    T[0] = f[0] + used * h
    predicted = [float(E[k][int(round((T[k] - f[k]) / h))]) for k in range(K)]
    return T.tolist(), predicted


# ------------------------------------------------------------------------------ planning
def _label(k: int, leg: Leg) -> str:
    return leg.name or f"leg {k}"


def _check_legs(planner: Any, legs: Sequence[Leg], start: np.ndarray,
                check: Callable[[np.ndarray, np.ndarray, Payload], Any] | None) -> list:
    """The legs' start configurations; ValueError naming the leg for a goal of the wrong
    shape, or (``check(start, goal, part)`` raising ValueError) a part in collision at a
    leg's start or goal, before any planning."""
    nq = planner.scenario.arm.nq
    q = start
    starts = []
    for k, leg in enumerate(legs, 1):
        try:
            goal = leg_configuration(leg.goal, nq, "goal")
            if leg.payload is not None and check is not None:
                check(q, goal, leg.payload)
        except ValueError as exc:
            raise type(exc)(f"cycle {_label(k, leg)}: {exc}") from None
        starts.append(q)
        q = goal
    return starts


def _fastest_error(cycle_time: float, fastest: list[float], dwell: float,
                   legs: Sequence[Leg]) -> CycleTimeTooShort:
    minimum = float(sum(fastest)) + dwell
    parts = " + ".join(f"{t:.3f}" for t in fastest)
    return CycleTimeTooShort(
        f"cycle_time {cycle_time:g} s is shorter than the fastest cycle, {minimum:.3f} s "
        f"(the fastest legs {parts} s and dwells {dwell:g} s); give a cycle_time of at "
        f"least {minimum:.3f} s", minimum, cycle_time, fastest, dwell)


def plan_cycle(planner: Any, legs: Sequence[Leg], *, start: Any,
               cycle_time: float | None = None, name: str = "cycle",
               check: Callable[[np.ndarray, np.ndarray, Payload], Any] | None = None) -> Cycle:
    """Plan the cycle ``legs`` from ``start`` (rad) with ``planner`` (module docstring);
    ``cycle_time`` (s): the whole cycle, motions and dwells. ValueError (naming the leg)
    for bad legs or a part in collision at a leg's start or goal;
    :class:`~mpd_pin.errors.CycleTimeTooShort` when ``cycle_time`` is below the fastest
    cycle; a leg's :class:`~mpd_pin.NoPathError` or (without ``cycle_time``)
    ``NoMotionWithinDuration`` names the leg. ``planner``: an
    :class:`~mpd_pin.EnergyPlanner` (its ``scenario`` and ``plan``); ``cycle_time`` is
    taken as checked (:meth:`~mpd_pin.EnergyPlanner.plan_cycle` checks it); ``check``: the
    planner's test of a part at a leg's start and goal."""
    w0, c0 = time.perf_counter(), time.process_time()
    legs = list(legs)
    if not legs or not all(isinstance(leg, Leg) for leg in legs):
        raise ValueError(f"plan_cycle: expected a non-empty list of mpd_pin.Leg, got {legs!r}")
    q0 = leg_configuration(start, planner.scenario.arm.nq, "start")
    starts = _check_legs(planner, legs, q0, check)
    dwell = float(sum(leg.dwell for leg in legs))
    calls = 0

    def plan_leg(k: int, cap: float | None) -> Plan:
        nonlocal calls
        leg = legs[k]
        calls += 1
        try:
            return planner.plan(starts[k], leg.goal, max_duration=cap, payload=leg.payload)
        except NoPathError as exc:
            raise NoPathError(f"cycle {_label(k + 1, leg)}: {exc}") from None
        except ValueError as exc:  # bad input (ConfigError too): one line naming the leg
            if type(exc) not in (ValueError, ConfigError):
                raise
            raise type(exc)(f"cycle {_label(k + 1, leg)}: {exc}") from None

    plans: list[Plan | None] = [None] * len(legs)
    caps: list[float | None] = [None] * len(legs)
    fastest: list[float | None] = [None] * len(legs)
    replanned = [False] * len(legs)
    allocation = None
    if cycle_time is None:
        for k, leg in enumerate(legs):
            try:
                plans[k] = plan_leg(k, None)
            except NoMotionWithinDuration as exc:
                raise NoMotionWithinDuration(f"cycle {_label(k + 1, leg)}: {exc}", exc.fastest,
                                             exc.plan, max_duration=exc.max_duration) from None
            fastest[k] = plans[k].fastest_duration
    else:
        budget = cycle_time - dwell - _SLACK_GUARD
        first_cap = min(max(budget, 1e-3), 3600.0)
        fronts = []
        short = False
        for k in range(len(legs)):
            try:
                plans[k] = plan_leg(k, first_cap)
                fastest[k] = float(plans[k].fastest_duration)
            except NoMotionWithinDuration as exc:  # even this leg alone does not fit
                fastest[k] = float(exc.fastest)
                short = True
        if short or budget < sum(fastest):
            raise _fastest_error(cycle_time, fastest, dwell, legs)
        for k in range(len(legs)):
            t_min, front = leg_front(plans[k])
            fastest[k] = max(float(fastest[k]), t_min)
            fronts.append(front)
        if budget < sum(fastest):  # the fronts' fastest points are later than reported
            raise _fastest_error(cycle_time, fastest, dwell, legs)
        dt = float(planner.scenario.options.dt)
        first_T, predicted = allocate(fronts, fastest, budget, dt=dt)
        left = budget
        for k in range(len(legs)):
            # caps on the dt grid: the duration rule screens whole RK4 steps up to the cap
            if k == len(legs) - 1:
                cap = max(fastest[k], dt * math.floor(left / dt + 1e-9))
            else:
                cap = allocate(fronts[k:], fastest[k:], left, dt=dt)[0][0]
            got = plans[k]
            if got.motion.duration > cap + 1e-9:  # the first plan does not fit: plan again
                try:
                    got = plan_leg(k, cap)
                except NoMotionWithinDuration as exc:
                    need = float(exc.fastest)
                    if need > left - sum(fastest[k + 1:]) + 1e-9:
                        fastest[k] = need
                        raise _fastest_error(cycle_time, fastest, dwell, legs) from None
                    cap = need
                    got = plan_leg(k, cap)
                replanned[k] = True
            plans[k], caps[k] = got, cap
            left -= float(got.motion.duration)
        allocation = {
            "method": "dynamic programme over a grid of the slack",
            "rule": "minimise sum_k E_k(T_k) subject to sum_k T_k + sum dwell <= cycle_time "
                    "and T_k >= fastest_k; E_k: the least energy of leg k's fronts at "
                    "durations <= T_k (screens calibrated by their simulated durations); "
                    "legs planned in order, the rest allocated again on the time left",
            "grid_steps": GRID_STEPS,
            "budget": budget + _SLACK_GUARD,
            "dwell": dwell,
            "fastest": fastest,
            "minimum_cycle_time": float(sum(fastest)) + dwell,
            "first_allocation": first_T,
            "predicted_energy": predicted,
            "planned": calls,
        }
    out, t = [], 0.0
    for k, (leg, plan) in enumerate(zip(legs, plans, strict=True)):
        drive = plan.scenario.drive()  # the arm as the leg carries it
        per_joint = dwell_energy(drive, plan.path[-1], leg.dwell)
        duration = float(plan.motion.duration)
        out.append(CycleLeg(index=k + 1, name=_label(k + 1, leg), plan=plan, start_time=t,
                            duration=duration, dwell=leg.dwell, payload=leg.payload,
                            dwell_energy=float(np.sum(per_joint)),
                            dwell_energy_per_joint=per_joint, max_duration=caps[k],
                            fastest_duration=None if fastest[k] is None else float(fastest[k]),
                            replanned=replanned[k]))
        t += duration + leg.dwell
    seconds = {"wall": time.perf_counter() - w0, "cpu": time.process_time() - c0,
               "plans": calls}
    return Cycle(out, cycle_time, allocation, seconds, name=name)


# ---------------------------------------------------------------------------- files
def run_cycle(planner: Any, scn: Any, out_dir: Path, *, replay: bool = True,
              plots: bool = True) -> dict[str, Any]:
    """``mpd-pin run`` of a scenario with a ``[cycle]``: plan it from ``[task] start`` and
    save it into ``out_dir`` (:meth:`Cycle.save`); returns cycle.json's content. A cycle
    time below the fastest cycle writes cycle.json with ``feasible`` false and the minimum,
    then raises :class:`~mpd_pin.errors.CycleTimeTooShort`. ``planner``: the scenario's
    :class:`~mpd_pin.EnergyPlanner`."""
    spec: CycleSpec = scn.cycle
    out_dir = Path(out_dir)

    def save_outcome(exc: CycleTimeTooShort) -> None:  # cycle.json says why
        write_json(out_dir / "cycle.json", to_jsonable({
            "format": CYCLE_FORMAT, "name": scn.name, "feasible": False, "reason": str(exc),
            "cycle_time": exc.max_duration, "minimum_cycle_time": exc.minimum,
            "fastest": exc.legs, "dwell": exc.dwell}))
        exc.args = (f"{exc}; {str(out_dir / 'cycle.json')!r} says why",)

    return plan_and_save(
        out_dir, lambda: planner.plan_cycle(spec.legs, start=scn.start,
                                            cycle_time=spec.cycle_time),
        lambda cycle: cycle.save(out_dir, replay=replay, plots=plots),
        outcome=CycleTimeTooShort, save_outcome=save_outcome)


def cycle_summary(scn: Any, result: dict[str, Any], out_dir: Path) -> str:
    """The line ``mpd-pin run`` prints for a cycle."""
    legs = ", ".join(f"{leg['name']} {leg['total_energy']:.4g} J in {leg['duration']:.3g} s"
                     for leg in result["legs"])
    cap = "" if result.get("cycle_time") is None else f" (cycle time {result['cycle_time']:g} s)"
    return (f"{scn.name}: cycle {result['total_energy']:.6g} J in {result['duration']:.3f} s"
            f"{cap}: {legs}; dwells {result['dwell_energy']:.4g} J -> {out_dir}/cycle.json")
