"""``diagnose`` on frames too coarse for the pulse: a warning in the JSON and on
stderr, with the peak's shortfall checked against a run with fine frames.

The struck Hertz chain (scenarios/chain_striker.yaml) has a solitary wave of
peak velocity 0.6816 that passes a granule in about 1.8 time units: frames 5
apart read 0.27 off the granules' velocities, 60 % low.
"""

import json
from pathlib import Path

import pytest

import granular_chain as gc
from granular_chain import diagnostics as dg
from granular_chain.cli import main

SCENE = Path(__file__).resolve().parents[1] / "scenarios" / "chain_striker.yaml"


def _summary(frame_dt: float):
    scene = gc.load_scene(SCENE, [f"output.dt={frame_dt}", "output.every=null"])
    return dg.summarize(gc.simulate(scene, progress=False), scene)


@pytest.fixture(scope="module")
def fine():
    return _summary(0.04)


@pytest.fixture(scope="module")
def coarse():
    return _summary(5.0)


def test_fine_frames_resolve_the_peak_without_a_warning(fine):
    assert fine["warnings"] == []
    frames = fine["pulse"]["frames"]
    assert fine["pulse"]["v_peak"] == pytest.approx(0.6816, abs=2e-4)  # docs/chains.md
    assert abs(frames["shortfall"]) < 1e-3
    assert frames["frame_interval"] == pytest.approx(0.04)
    # half-maximum width 1.49 granules at 0.8405 granules per unit time
    assert frames["pulse_duration"] == pytest.approx(1.49 / 0.8405, rel=0.02)


def test_coarse_frames_warn_with_the_shortfall_the_fine_run_measures(coarse, fine):
    v_fine = fine["pulse"]["v_peak"]
    frames = coarse["pulse"]["frames"]
    assert coarse["pulse"]["v_peak"] == pytest.approx(0.270, abs=2e-3)  # the number
    true_shortfall = 1.0 - coarse["pulse"]["v_peak"] / v_fine  # 0.604
    assert frames["shortfall"] == pytest.approx(true_shortfall, abs=0.03)
    assert frames["v_peak_snapshots"] == pytest.approx(v_fine, rel=0.05)
    assert frames["frame_interval"] == pytest.approx(5.0)
    [warning] = coarse["warnings"]
    assert "frames 5 time units apart" in warning
    assert f"{100 * frames['shortfall']:.0f}% below" in warning
    assert f"about {frames['v_peak_snapshots']:.3g}" in warning


def test_diagnose_command_says_it_on_stderr_and_in_the_json(capsys):
    code = main(["diagnose", str(SCENE), "--set", "output.dt=5", "--set", "output.every=null"])
    captured = capsys.readouterr()
    assert code == 0
    summary = json.loads(captured.out)
    [warning] = summary["warnings"]
    lines = captured.err.strip().splitlines()
    assert lines == [f"granular-chain: warning: {warning}"]
