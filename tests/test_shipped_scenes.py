"""Every scene shipped in ``scenarios/`` runs as written, succeeds, and warns of
nothing about itself (for instance granules i and i+2 that overlap: the radius of a
scene struck at v0 = 1 in scaled units must exceed half the largest sum of two
neighbouring overlaps)."""

from pathlib import Path

import pytest

import granular_chain as gc

SCENES = sorted((Path(__file__).resolve().parents[1] / "scenarios").glob("*.yaml"))


def test_scenes_are_found():
    assert len(SCENES) >= 19


@pytest.mark.parametrize("path", SCENES, ids=lambda p: p.stem)
def test_shipped_scene_runs_without_warnings(path):
    result = gc.simulate(gc.load_scene(path), progress=False)
    assert result.success, result.message
    assert result.info.get("warnings", []) == []
