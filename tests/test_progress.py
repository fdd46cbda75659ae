"""A long command's progress: a line per tenth of the work off a terminal (issue 37, "What a
newcomer met": a compare in a log printed nothing for twenty minutes)."""

from __future__ import annotations

import io
import re

from gnssframework.progress import Progress


def test_off_a_terminal_one_line_per_tenth_with_the_elapsed_time():
    out = io.StringIO()  # not a terminal
    with Progress(72, "vector_tracking", "batch", stream=out) as p:
        for _ in range(72):
            p.update()
    lines = out.getvalue().splitlines()
    assert len(lines) == 10
    assert lines[0].startswith("vector_tracking: 8/72 batch (11 %), ")
    assert lines[-1].startswith("vector_tracking: 72/72 batch (100 %), ")
    assert all(re.search(r", \d+:\d\d:\d\d elapsed$", line) for line in lines)


def test_set_never_moves_back_and_a_jump_prints_each_tenth_once():
    out = io.StringIO()
    p = Progress(100, "rec.bin", "%", stream=out)
    p.set(35)
    p.set(20)  # a late report of less work done
    assert p.done == 35 and len(out.getvalue().splitlines()) == 3
    p.set(100)
    assert [int(line.split()[1].split("/")[0]) for line in out.getvalue().splitlines()][-1] == 100
    assert len(out.getvalue().splitlines()) == 10


def test_a_terminal_gets_a_bar_not_lines():
    out = io.StringIO()
    with Progress(10, "x", "batch", stream=out, terminal=True) as p:
        p.update(10)
    assert "x: 10/10 batch (100 %)" not in out.getvalue() and "10/10" in out.getvalue()
