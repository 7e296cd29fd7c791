"""A forked child waited for with a deadline: a test of a hang fails instead of hanging (issue 38 audit)."""

from __future__ import annotations

import os
import signal
import time

import pytest


def exit_code_of(pid: int, seconds: float, what: str) -> int:
    """The exit code of the child ``pid``; killed, and the test failed with "``what`` in N s", past ``seconds``."""
    deadline = time.monotonic() + seconds
    while (done := os.waitpid(pid, os.WNOHANG))[0] == 0 and time.monotonic() < deadline:
        time.sleep(0.05)
    if done[0] == 0:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        pytest.fail(f"{what} in {seconds:g} s")
    return os.waitstatus_to_exitcode(done[1])
