"""Exceptions raised by mpd_pin."""

from __future__ import annotations


class MpdPinError(Exception):
    """Base class of every error raised on purpose by mpd_pin."""


class NoPathError(MpdPinError):
    """The goal cannot be reached from the start in the current graph."""
