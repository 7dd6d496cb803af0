"""What the writers' thread of a run costs while no frame comes: CPU time over a
few seconds of a frame log with a writer attached and nothing recorded.

    python benchmarks/idle_writers.py --seconds 3
"""

import argparse
import json
import time

from granular_chain.frames import FrameLog


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
    log.finish()
    print(json.dumps({"seconds": a.seconds, "core_percent": round(100 * cpu / a.seconds, 2)}))


if __name__ == "__main__":
    main()
