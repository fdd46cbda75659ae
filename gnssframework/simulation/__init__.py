"""Impairments and scenarios: scintillation, colored noise, multipath, cycle slips, clocks."""

from . import clock, impairments, scintillation

__all__ = ["clock", "impairments", "scintillation"]
