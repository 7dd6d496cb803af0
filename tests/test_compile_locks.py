"""GRANULAR_CHAIN_COMPILE_LOCKS: a process asking for a kernel another is compiling
waits for it (and then loads it from numba's cache) instead of compiling it too."""

import os
import subprocess
import sys
import time

import numba
import numpy as np

from granular_chain._compile import LOCK_DIR_ENV, _compile_lock, _literal_type
from granular_chain.forces import total_potential

CHILD = """
import numpy as np
from granular_chain._compile import specialised
from granular_chain.forces import total_potential
args = (1, 0, 0, np.zeros(3), np.zeros(4), np.ones(4), np.full(4, 2.0))
print("asking", flush=True)
print(specialised(total_potential, args, (0, 1, 2))(*args))
"""


def test_a_second_process_waits_for_the_kernel_being_compiled(tmp_path):
    args = (1, 0, 0, np.zeros(3), np.zeros(4), np.ones(4), np.full(4, 2.0))
    sig = tuple(_literal_type(a) if i < 3 else numba.typeof(a) for i, a in enumerate(args))
    env = {**os.environ, LOCK_DIR_ENV: str(tmp_path)}
    os.environ[LOCK_DIR_ENV], saved = str(tmp_path), os.environ.get(LOCK_DIR_ENV)
    try:
        with _compile_lock(total_potential, sig):  # as if this process were compiling it
            child = subprocess.Popen([sys.executable, "-c", CHILD], env=env, text=True,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE)
            assert child.stdout.readline() == "asking\n"
            time.sleep(1.0)  # (a cached kernel loads in milliseconds)
            assert child.poll() is None, child.communicate()  # waiting for the lock
        out, err = child.communicate(timeout=120)
    finally:
        if saved is None:
            del os.environ[LOCK_DIR_ENV]
        else:
            os.environ[LOCK_DIR_ENV] = saved
    assert child.returncode == 0, err
    assert float(out) == 0.0  # (no overlap: no elastic energy)
    assert len(list(tmp_path.glob("*.lock"))) == 1
