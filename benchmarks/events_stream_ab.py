"""Event stepper: are the Results and the frames written the same bit for bit in two checkouts?

Runs six event-stepper scenes through ``simulate(scene, writers=[...])`` with each
checkout on PYTHONPATH (a subprocess each) and compares every field of the Result
(frames, ledger, end state, events, counts, status, message, info) and every frame
the writer received (step, t, x, v, f, energies). Prints one line per scene.

    git -C . archive <commit> | tar -x -C /tmp/old
    python benchmarks/events_stream_ab.py /tmp/old .
"""

import os
import pickle
import subprocess
import sys
import tempfile

import numpy as np

SCENES = {
    "hertz30_dt": {"granules": {"count": 30, "velocity": {0: 0.1}, "friction": {
        "kinetic": [0.0] * 15 + [2e-5] * 15, "viscous": 1e-4}}, "contacts": {"exponent": 2.5},
        "walls": {"right": {"gap": 0.0, "exponent": 2.5}}, "run": {"t_end": 60.0},
        "output": {"dt": 0.5}},
    "lin8_events": {"granules": {"count": 8, "velocity": {0: 1.0}, "friction": {"kinetic": 0.02}},
                    "contacts": {"exponent": 2.0}, "run": {"t_end": 6.0}},
    "two_modal": {"granules": {"count": 2, "velocity": {0: 1.0}, "friction": {"viscous": 0.1}},
                  "contacts": {"exponent": 2.0}, "run": {"t_end": 5.0}, "output": {"dt": 0.01}},
    "long100": {"granules": {"count": 100, "velocity": {0: 1.0}}, "contacts": {"exponent": 2.5},
                "run": {"t_end": 40.0}},
    "physical": {"units": "physical", "granules": {
        "count": 4, "mass": 0.033, "radius": 0.01, "velocity": [0.5, 0.0, 0.0, 0.0],
        "material": {"young": 2e11, "poisson": 0.3},
        "friction": {"kinetic": [0.0, 0.05, 0.0, 0.0], "viscous": [0.0, 0.2, 0.0, 0.0]}},
        "contacts": {"stiffness": "hertz", "exponent": 2.5}, "run": {"t_end": 1e-3},
        "output": {"dt": 1e-5}},
    "long1000": {"granules": {"count": 1000, "velocity": {0: 1.0}, "friction": {"viscous": 1e-3}},
                 "contacts": {"exponent": 2.5}, "run": {"t_end": 30.0}, "output": {"dt": 0.01}},
}

CHILD = """
import pickle, sys
import granular_chain as gc
from benchmarks_events_stream_ab import SCENES
class Collect:
    def __init__(self): self.frames = []
    def write_frame(self, f):
        self.frames.append((f.step, f.t, f.x.copy(), f.v.copy(), f.f.copy(), f.kinetic,
                            f.potential, f.coulomb, f.viscous, f.initial))
    def close(self, r): pass
out = {}
for name, spec in SCENES.items():
    spec = dict(spec, name=name, run=dict(spec["run"], stepper="event"))
    c = Collect()
    r = gc.simulate(gc.scene_from_dict(spec), progress=False, writers=[c])
    e = r.energy
    out[name] = (dict(t=r.t, x=r.x, v=r.v, f=r.f, kinetic=e.kinetic, potential=e.potential,
                      coulomb=e.coulomb, viscous=e.viscous, initial=e.initial,
                      streamed=e.streamed_error, status=str(r.status), message=r.message,
                      steps=r.steps, t_final=r.t_final, x_final=r.x_final, v_final=r.v_final,
                      events=[(ev.t, ev.kind, ev.index) for ev in r.events], counts=r.event_counts,
                      info=r.info), c.frames)
pickle.dump(out, open(sys.argv[1], "wb"))
"""


def same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(same(p, q) for p, q in zip(a, b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, float) and a != a:
        return b != b
    return a == b


def run(checkout: str, folder: str):
    path = os.path.join(folder, os.path.basename(os.path.abspath(checkout)) + ".pkl")
    here = os.path.dirname(os.path.abspath(__file__))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([os.path.abspath(checkout), folder])}
    with open(os.path.join(folder, "benchmarks_events_stream_ab.py"), "w") as fh:
        fh.write(open(os.path.join(here, "events_stream_ab.py")).read())
    subprocess.run([sys.executable, "-c", CHILD, path], env=env, check=True)
    return pickle.load(open(path, "rb"))


def main():
    with tempfile.TemporaryDirectory() as folder:
        old, new = run(sys.argv[1], folder), run(sys.argv[2], folder)
    for name in SCENES:
        (ra, fa), (rb, fb) = old[name], new[name]
        diff = [k for k in ra if not same(ra[k], rb[k])]
        print(f"{name}: {len(fa)} frames, Result fields differing: {diff or 'none'}, "
              f"frames written identical: {same(fa, fb)}")


if __name__ == "__main__":
    main()
