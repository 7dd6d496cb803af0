"""What handing a frame to another core costs the stepping core, with no writer code at all.

At an output frame the Verlet driver writes x = x0 + u, v and f (3 N doubles)
into arrays the frame log lends; the writers' thread then reads them on the
other core. This benchmark isolates that hand-off from the engine: a compiled
loop writes a frame of N granules into one of a few cycling frame arrays, then
sweeps a working set about as large as a Verlet kernel's for N granules (so the
frame arrays leave the core's cache between frames, as they do in a run), and

- ``alone``: nobody reads the frames;
- ``read``: a second thread copies each frame out (as a frame writer does) soon
  after it is written.

It prints the time the stepping core spends writing one frame, in
microseconds, for each way and each count of cycling frame arrays: the
difference between ``read`` and ``alone`` is what moving the cache lines
between the cores costs, a floor for any writer on another core (thread or
process) that receives every frame.

    python benchmarks/frame_handoff.py --grains 10000
"""

import argparse
import json
import threading
import time

import numba
import numpy as np


@numba.njit(cache=True, nogil=False)
def write_frame(u, v, f, x0, x, v_out, f_out):
    """x = x0 + u, v, f into the frame's arrays (the stores of the driver's scan)."""
    for i in range(u.size):
        x[i] = x0[i] + u[i]
        v_out[i] = v[i]
        f_out[i] = f[i]


@numba.njit(cache=True, nogil=True)
def copy_out(rows, x, v, f):
    """What a frame writer does with a frame: copy it into its own buffer."""
    for i in range(x.size):
        rows[0, i] = x[i]
        rows[1, i] = v[i]
        rows[2, i] = f[i]


@numba.njit(cache=True, nogil=True)
def sweep(work):
    """Touch a kernel-sized working set (and spend some time between frames)."""
    s = 0.0
    for _ in range(4):
        for i in range(work.size):
            s += work[i]
            work[i] = s * 1e-300
    return s


def measure(grains: int, arrays: int, read: bool, frames: int) -> float:
    rng = np.random.default_rng(1)
    u, v, f = (rng.random(grains) for _ in range(3))
    x0 = np.arange(grains, dtype=np.float64)
    slots = [tuple(np.empty(grains) for _ in range(3)) for _ in range(arrays)]
    buffer = np.empty((64, 3, grains))
    work = rng.random(16 * grains)  # about a Verlet kernel's arrays for N granules
    pending, done = [], [False]

    def reader():
        row = 0
        while not done[0] or pending:
            if pending:
                copy_out(buffer[row % 64], *pending.pop(0))
                row += 1
            else:
                time.sleep(0.0002)

    thread = threading.Thread(target=reader)
    if read:
        thread.start()
    write_frame(u, v, f, x0, *slots[0])
    spent = 0.0
    for k in range(frames):
        slot = slots[k % arrays]
        begin = time.perf_counter()
        write_frame(u, v, f, x0, *slot)
        spent += time.perf_counter() - begin
        if read:
            pending.append(slot)
        sweep(work)
    done[0] = True
    if read:
        thread.join()
    return spent / frames * 1e6


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--grains", type=int, default=10_000)
    p.add_argument("--frames", type=int, default=2000)
    p.add_argument("--repeat", type=int, default=3)
    a = p.parse_args()
    copy_out(np.empty((3, 2)), np.zeros(2), np.zeros(2), np.zeros(2))
    sweep(np.zeros(2))
    for arrays in (3, 8):
        for read in (False, True):
            us = min(measure(a.grains, arrays, read, a.frames) for _ in range(a.repeat))
            print(json.dumps({"grains": a.grains, "frame_arrays": arrays,
                              "way": "read" if read else "alone", "us_per_frame": round(us, 1)}))


if __name__ == "__main__":
    main()
