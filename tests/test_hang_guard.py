"""The suite's guard against a hung child process (conftest.finish): the child prints
its threads' stacks and the test fails naming it, instead of waiting for ever."""

import contextlib
import os
import signal
import subprocess
import sys

import pytest
from conftest import finish

SLEEPER = "import time\ndef stuck_here():\n    time.sleep(600)\nstuck_here()\n"


def test_a_hung_child_prints_its_stack_and_fails_the_test():
    proc = subprocess.Popen([sys.executable, "-c", SLEEPER], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    with pytest.raises(pytest.fail.Exception) as failed:
        finish(proc, "the sleeper", seconds=1.0)
    message = str(failed.value)
    assert "hung: the sleeper had not ended after 1 s" in message
    assert "stuck_here" in message  # (the fault handler's dump of its stack)
    assert proc.returncode is not None


def test_a_child_that_ends_gives_its_status_and_output():
    proc = subprocess.Popen([sys.executable, "-c", "import sys; print('out'); "
                             "sys.stderr.write('err'); sys.exit(3)"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert finish(proc, "a short child") == (3, "out\n", "err")


# A child that ignores SIGABRT and leaves a grandchild holding its pipes: the guard
# kills the child and still returns, instead of reading the pipes until the grandchild ends.
DEAF_PARENT = ("import signal, subprocess, sys, time\n"
               "signal.signal(signal.SIGABRT, signal.SIG_IGN)\n"
               "subprocess.Popen([sys.executable, '-c', 'import time; time.sleep(600)'])\n"
               "time.sleep(600)\n")


def test_a_hung_child_whose_grandchild_holds_its_pipes_still_fails_the_test():
    proc = subprocess.Popen([sys.executable, "-c", DEAF_PARENT], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        with pytest.raises(pytest.fail.Exception) as failed:
            finish(proc, "the deaf parent", seconds=1.0, grace=1.0)
        assert "hung: the deaf parent had not ended after 1 s" in str(failed.value)
        assert "still held open" in str(failed.value)
        assert proc.returncode == -signal.SIGKILL
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)  # the grandchild
