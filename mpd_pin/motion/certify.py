"""Certification of non-stop curves by Bernstein boxes (docs/design.md §9c).

On a sub-interval of one polynomial piece a degree-5 curve lies in the convex hull of its
Bernstein coefficients (:func:`~mpd_pin.motion.spline.arc_boxes`): joint-space boxes that
:meth:`~mpd_pin.collision.CollisionChecker.boxes_clear` certifies whole. Boxes are split
until they fit the check's level, and failing ones bisected down to ``min_step``.
"""

from __future__ import annotations

import numpy as np

from .spline import ViaSpline, arc_boxes, pieces, unit_knots, via_spline

__all__ = ["first_failure", "certified_pieces"]


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


def certified_pieces(W: np.ndarray, checker, resolution: float, vlim: np.ndarray
                      ) -> list[tuple[int, int]]:
    """Split the waypoints into pieces whose non-stop curves are certified free: a piece
    whose curve fails gets a stop at the interior via point nearest the failure."""
    todo, done = [(0, W.shape[0] - 1)], []
    while todo:
        i, j = todo.pop()
        if j - i < 2 or checker is None:
            done.append((i, j))
            continue
        vs = via_spline(W[i : j + 1], unit_knots(W[i : j + 1], vlim))
        fail = first_failure(checker, vs, resolution)
        if fail is None:
            done.append((i, j))
            continue
        inner = np.arange(1, j - i)
        k = i + int(inner[np.argmin(np.abs(vs.knots[inner] - fail))])
        todo += [(i, k), (k, j)]
    return sorted(done)
