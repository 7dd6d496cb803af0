"""Cost of output.events on the Verlet stepper: a struck chain (benchmarks/throughput.py's scene), N = 10^4,
20000 steps, with the log off and on, three runs each after a warm-up; million grain-steps per second.

    PYTHONPATH=. python benchmarks/events_log_cost.py
"""
import sys, time, json
sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
import throughput, granular_chain as gc
from granular_chain.model import build_model
import importlib
sim = importlib.import_module("granular_chain.simulate")
for feat in ("frictionless", "coulomb+viscous"):
    for N, steps in ((10000, 20000),):
        rates = {}
        for events in (False, True, False, True, False, True):
            sc = throughput.chain_scene(N, steps, feat)
            sc = sc.model_copy(update={"output": sc.output.model_copy(update={"events": events})})
            if events not in rates:
                w = throughput.chain_scene(N, 10, feat)
                w = w.model_copy(update={"output": w.output.model_copy(update={"events": events})})
                sim._simulate_verlet(w, build_model(w), False)
                rates[events] = []
            m = build_model(sc)
            t = time.perf_counter(); r = sim._simulate_verlet(sc, m, False); el = time.perf_counter() - t
            rates[events].append(N * steps / el / 1e6)
            ne = len(r.events)
        print(json.dumps({"N": N, "steps": steps, "features": feat, "off_M": sorted(rates[False]),
                          "on_M": sorted(rates[True]), "events": ne}), flush=True)
