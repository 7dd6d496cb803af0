"""CPU seconds to compile one more feature set once another is compiled, by function.

A pair of 3-granule scenes (``compile_mix.scene``) in one process on an empty cache: the
first is run (its kernels and their shared callees compiled), then the second, timed,
with the CPU time of each compiled function apart from the callees it compiles (numba's
"numba:compile" events). Run a tree beside another on the two cores, then swap them::

    NUMBA_CACHE_DIR=$(mktemp -d) taskset -c 0 python benchmarks/compile_increment.py event-coulomb

Pairs: ``event-coulomb`` (event stepper, n = 5/2: frictionless, then Coulomb),
``verlet-walls`` (Verlet, n = 5/2: frictionless, then Coulomb between walls),
``forced`` (the forced Verlet kernel: a linear dashpot at n = 2, then Coulomb and a
linear dashpot at n = 5/2).
"""

import argparse
import collections
import time
import warnings

from numba.core import event

import granular_chain as gc
from compile_mix import scene

DASHPOT = {"model": "linear", "coefficient": 0.05}
PAIRS = {
    "event-coulomb": (scene(2.5, "event"), scene(2.5, "event", {"kinetic": 0.01})),
    "verlet-walls": (scene(2.5, "verlet"), scene(2.5, "verlet", {"kinetic": 0.01}, walls=True)),
    "forced": (scene(2.0, "verlet", damping=DASHPOT),
               scene(2.5, "verlet", {"kinetic": 0.01}, damping=DASHPOT)),
}


class SelfTimes(event.Listener):
    """CPU seconds of each compile, the compiles nested in it taken out."""

    def __init__(self):
        self.stack = []
        self.seconds = collections.Counter()

    def on_start(self, ev):
        now = time.process_time()
        if self.stack:
            self.stack[-1][1] += now - self.stack[-1][2]
        self.stack.append([ev.data["dispatcher"].py_func.__qualname__, 0.0, now])

    def on_end(self, ev):
        now = time.process_time()
        name, spent, since = self.stack.pop()
        self.seconds[name] += spent + now - since
        if self.stack:
            self.stack[-1][2] = now


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("pair", choices=sorted(PAIRS))
    first, second = PAIRS[p.parse_args().pair]
    warnings.simplefilter("ignore")
    gc.simulate(first, progress=False)
    times = SelfTimes()
    start = time.process_time()
    with event.install_listener("numba:compile", times):
        gc.simulate(second, progress=False)
    print(f"second feature set: cpu {time.process_time() - start:.1f} s")
    for name, seconds in times.seconds.most_common(6):
        print(f"  {seconds:6.2f} s  {name}")


if __name__ == "__main__":
    main()
