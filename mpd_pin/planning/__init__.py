"""Stage 5 — planning: the energy roadmap, execution with sensing and repair, hazard re-planning.

docs/design.md §4–§5. Builds on :mod:`mpd_pin.dynamics` (edge costs),
:mod:`mpd_pin.collision` (validity) and :mod:`mpd_pin.search` (graph search).
"""
