"""Receiver building blocks: loop filters, closed-loop tracking, jitter formulas."""
