"""Every result bit for bit as stored: all scenes, both steppers, the paper's cases.

The cases and their fingerprints (SHA-256 of each result array, status, steps,
event counts; the exact n = 2 reference's numbers as exact mantissa tuples)
come from ``benchmarks/tiled_compare.py``; ``tests/reference/bit_identical.json``
holds them. A change that is meant to alter results regenerates the file
(``python benchmarks/tiled_compare.py --dump tests/reference/bit_identical.json``)
and says in its commit which cases changed and by how much.

numba compiles for the host CPU, and another instruction set may round
differently: on a CPU other than the one recorded in the file the module is
skipped, with the reason shown. A CPU that has the recorded one's instructions
(an AVX-512 AMD Zen 4 has rocketlake's) runs it by compiling for the recorded CPU,
in a numba cache of its own::

    NUMBA_CPU_NAME=rocketlake NUMBA_CACHE_DIR=/tmp/numba-rocketlake pytest tests/test_bit_identical.py
"""

import importlib.util
import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = json.loads((ROOT / "tests" / "reference" / "bit_identical.json").read_text())


def _compare_module():
    spec = importlib.util.spec_from_file_location("tiled_compare",
                                                  ROOT / "benchmarks" / "tiled_compare.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


TC = _compare_module()
CASES = TC.cases()

if TC.machine()["cpu"] != REFERENCE["machine"]["cpu"]:
    pytest.skip(f"fingerprints made on CPU {REFERENCE['machine']['cpu']}, this is "
                f"{TC.machine()['cpu']} (NUMBA_CPU_NAME={REFERENCE['machine']['cpu']} and a "
                f"NUMBA_CACHE_DIR of its own run it where that CPU's instructions exist)",
                allow_module_level=True)


def test_every_case_has_a_fingerprint():
    assert sorted(CASES) == sorted(REFERENCE["cases"])


@pytest.mark.parametrize("name", sorted(CASES))
def test_bit_identical(name):
    assert TC.run_case(name, CASES[name]) == REFERENCE["cases"][name]
