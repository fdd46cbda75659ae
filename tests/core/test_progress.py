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


def test_a_recordings_lines_give_the_signal_time_processed_and_the_real_time_factor(monkeypatch):
    from gnssframework import progress

    now = [100.0]
    monkeypatch.setattr(progress.time, "monotonic", lambda: now[0])
    out = io.StringIO()
    p = Progress(100, "rec.bin", "%", stream=out, signal_s=32.0)
    now[0] += 8.0  # 8 s of wall clock for the first 10 % (3.2 s of signal): 0.40x real time
    p.set(10)
    now[0] += 2.0
    p.set(20)  # 6.4 s of signal in 10 s: 0.64x
    lines = out.getvalue().splitlines()
    assert lines == [
        "rec.bin: 10/100 % (10 %), 3.2/32.0 s of signal, 0.40x real time, 0:00:08 elapsed",
        "rec.bin: 20/100 % (20 %), 6.4/32.0 s of signal, 0.64x real time, 0:00:10 elapsed",
    ]
    progress.phase("rec.bin", "acquisition of 3 PRNs", 90.0, stream=out)
    assert out.getvalue().splitlines()[-1] == "rec.bin: acquisition of 3 PRNs, 0:00:20 elapsed"


def test_a_terminal_bar_shows_the_signal_time_and_speed():
    out = io.StringIO()
    with Progress(10, "rec.bin", "%", stream=out, terminal=True, signal_s=5.0) as p:
        p.update(10)
    assert "5.0/5.0 s of signal" in out.getvalue() and "x real time" in out.getvalue()
