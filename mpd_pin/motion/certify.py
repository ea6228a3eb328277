"""Certification of non-stop curves by Bernstein boxes (docs/design.md §9c).

On a sub-interval of one polynomial piece a degree-5 curve lies in the convex hull of its
Bernstein coefficients (:func:`~mpd_pin.motion.spline.arc_boxes`): joint-space boxes that
:meth:`~mpd_pin.collision.CollisionChecker.boxes_clear` certifies whole. Boxes are split
until they fit the check's level, and failing ones bisected down to ``min_step``.
"""

from __future__ import annotations

import numpy as np

from .outcome import RANGE_TOLERANCE
from .spline import ViaSpline, arc_boxes, pieces, unit_knots, via_spline

__all__ = ["first_failure", "range_failure", "certified_pieces"]


def _fit(checker, vs: ViaSpline, a: np.ndarray, b: np.ndarray, h: float):
    """Split the sub-arcs [a, b] (unit time, s) until each one's Bernstein box fits level
    ``h`` (rad); returns a, b (sorted) and the boxes' centres and half-widths."""
    while True:
        C, D = arc_boxes(vs, a, b)
        big = checker.box_sizes(C, D) > h
        if not big.any():
            return a, b, C, D
        mid = (a[big] + b[big]) / 2
        a = np.concatenate([a[~big], a[big], mid])
        b = np.concatenate([b[~big], mid, b[big]])
        order = np.argsort(a)
        a, b = a[order], b[order]


def first_failure(checker, vs: ViaSpline, resolution: float, min_step: float = 1e-6
                   ) -> float | None:
    """Certify the spline's whole curve (joint-space boxes from its Bernstein hulls,
    :func:`~mpd_pin.motion.spline.arc_boxes`); None if free, else the unit time (s) of the
    first sub-arc that is in collision or too close to call."""
    h = float(resolution)
    a, b, C, D = _fit(checker, vs, *pieces(vs), h)
    while a.size:
        clear, hit = checker.boxes_clear(C, D, h)
        if hit.any():
            return float(a[np.flatnonzero(hit)[0]])
        a, b = a[~clear], b[~clear]
        if not a.size:
            return None
        h /= 2
        if h < min_step:
            return float(a[0])
        mid = (a + b) / 2
        a, b, C, D = _fit(checker, vs, np.concatenate([a, mid]), np.concatenate([mid, b]), h)
    return None


def range_failure(vs: ViaSpline, lo: np.ndarray, hi: np.ndarray,
                  tol: float = RANGE_TOLERANCE, min_step: float = 1e-9) -> float | None:
    """The unit time (s) of a point where the curve passes the joint range [lo, hi] (rad,
    (nq,); ±inf: none) by more than ``tol`` (rad), None when it stays within: the
    Bernstein boxes of its pieces, kept while a box reaches past a limit (the curve at the
    ends and middle of such an arc tested), bisected down to ``min_step`` (then taken as
    passing). The range of a curve through waypoints within it: a via spline swings past
    its waypoints (a Panda bench query's, by 4.2 rad)."""
    a, b = pieces(vs)
    lo_t, hi_t = np.asarray(lo, float) - tol, np.asarray(hi, float) + tol
    while a.size:
        C, D = arc_boxes(vs, a, b)
        reach = ((C - D) < lo_t) | ((C + D) > hi_t)
        keep = reach.any(axis=1)
        if not keep.any():
            return None
        a, b = a[keep], b[keep]
        t = np.concatenate([a, 0.5 * (a + b), b])
        q = vs.spline(t)
        out = ((q < lo_t) | (q > hi_t)).any(axis=1)
        if out.any():
            return float(t[out].min())
        if float(np.max(b - a)) < min_step:
            return float(a[0])
        mid = 0.5 * (a + b)
        a, b = np.concatenate([a, mid]), np.concatenate([mid, b])
    return None


def certified_pieces(W: np.ndarray, checker, resolution: float, vlim: np.ndarray,
                     limits: tuple[np.ndarray, np.ndarray] | None = None
                     ) -> list[tuple[int, int]]:
    """Split the waypoints into pieces whose non-stop curves are certified free (and, with
    ``limits`` = (lower, upper) rad, :func:`~mpd_pin.motion.outcome.joint_range`, within
    the joint range, :func:`range_failure`): a piece whose curve fails gets a stop at the
    interior via point nearest the failure. A piece of one segment is a straight line
    between its waypoints, free and within the range as they are."""
    todo, done = [(0, W.shape[0] - 1)], []
    while todo:
        i, j = todo.pop()
        if j - i < 2 or (checker is None and limits is None):
            done.append((i, j))
            continue
        vs = via_spline(W[i : j + 1], unit_knots(W[i : j + 1], vlim))
        fail = None if checker is None else first_failure(checker, vs, resolution)
        if fail is None and limits is not None:
            fail = range_failure(vs, *limits)
        if fail is None:
            done.append((i, j))
            continue
        inner = np.arange(1, j - i)
        k = i + int(inner[np.argmin(np.abs(vs.knots[inner] - fail))])
        todo += [(i, k), (k, j)]
    return sorted(done)
