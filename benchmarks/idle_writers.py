"""What the writers' thread of a run costs while no frame comes: CPU time over a
few seconds of a frame log with a writer attached and nothing recorded; then how
long a checkpoint's ``sync`` waits for one frame recorded after that pause.

    python benchmarks/idle_writers.py --seconds 3
"""

import argparse
import json
import time

from granular_chain.frames import Frame, FrameLog


class _Sink:
    def write_frame(self, frame):
        pass

    def close(self, result):
        pass


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seconds", type=float, default=3.0)
    a = p.parse_args()
    log = FrameLog([_Sink()], keep=False, background=True)
    cpu = time.process_time()
    time.sleep(a.seconds)
    cpu = time.process_time() - cpu
    x, v, f = log.lend(10)
    log.record(Frame(0, 0.0, x, v, f, 0.0, 0.0, 0.0, 0.0, 1.0))
    begin = time.perf_counter()
    log.sync()
    sync = time.perf_counter() - begin
    log.finish()
    print(json.dumps({"seconds": a.seconds, "core_percent": round(100 * cpu / a.seconds, 2),
                      "sync_after_pause_ms": round(1e3 * sync, 3)}))


if __name__ == "__main__":
    main()
