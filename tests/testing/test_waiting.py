"""The test kit's wait (carav_stream/testing/waiting.py): it waits while the work progresses and fails when it
stands still."""
import os
import time

import pytest

from carav_stream.testing.waiting import group_cpu_s, wait_until


def test_a_wait_outlasts_its_stall_time_while_progress_rises_and_returns_the_predicate_s_value():
    start = time.monotonic()
    ticks = iter(range(10 ** 6))
    found = wait_until(lambda: time.monotonic() - start > 0.6 and "done", "the work", lambda: next(ticks),
                       stall_s=0.2, min_step=1, interval_s=0.01)
    assert found == "done" and time.monotonic() - start > 0.6            # three stall times, never stalled


def test_a_wait_fails_naming_what_it_waited_for_when_progress_stands_still():
    start = time.monotonic()
    with pytest.raises(AssertionError, match=r"no progress for 0 s waiting for the frames"):
        wait_until(lambda: False, "the frames", lambda: 5.0, stall_s=0.2, interval_s=0.01)
    assert 0.2 <= time.monotonic() - start < 2


def test_progress_smaller_than_the_step_does_not_restart_the_deadline():
    work = iter(x * 0.01 for x in range(10 ** 6))            # a process that is only polling: 0.01 a look
    with pytest.raises(AssertionError, match="no progress"):
        wait_until(lambda: False, "x", lambda: next(work), stall_s=0.2, min_step=0.5, interval_s=0.01)


def test_a_wait_that_progresses_without_end_fails_at_the_cap():
    ticks = iter(range(10 ** 6))
    with pytest.raises(AssertionError, match=r"still waiting for x after 0 s \(the cap\)"):
        wait_until(lambda: False, "x", lambda: next(ticks), stall_s=10, cap_s=0.3, min_step=1, interval_s=0.01)


def test_group_cpu_s_counts_the_cpu_time_of_a_process_group():
    before = group_cpu_s(os.getpgrp())
    t = time.process_time()
    while time.process_time() - t < 0.3:                     # this process's own work, in its own group
        pass
    assert group_cpu_s(os.getpgrp()) - before >= 0.2
    assert group_cpu_s(2 ** 22 + 12345) == 0.0                # no such group
