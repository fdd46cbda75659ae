"""Tracking: loop filters, scalar and vector closed-loop tracking, loop bandwidth, jitter and the PCRB."""
