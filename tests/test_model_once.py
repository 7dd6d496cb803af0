"""A command-line run builds the scene's Model once: the checks before any work
(preflight), the kernels' warm-up and the run share it."""

from pathlib import Path

from granular_chain import model as model_module
from granular_chain.cli import main

SCENE = """name: once
granules: {count: 6, velocity: {0: 1.0}}
contacts: {exponent: 2.5}
run: {dt: 0.01, t_end: 2.0}
output: {every: 10}
"""


def test_a_cli_run_builds_its_model_once(tmp_path, monkeypatch):
    (tmp_path / "s.yaml").write_text(SCENE)
    built = []
    real = model_module.build_model

    def counting(scene):
        built.append(scene.run.t_end)
        return real(scene)

    for module in ("granular_chain.budget", "granular_chain.warmup", "granular_chain.result"):
        monkeypatch.setattr(f"{module}.build_model", counting)
    assert main(["run", str(tmp_path / "s.yaml"), "--quiet", "--out",
                 str(tmp_path / "out")]) == 0
    # the scene's, once; the warm-up's two-step copy is a scene of its own (t_end 0.02)
    assert built.count(2.0) == 1, built
    assert (Path(tmp_path / "out") / "summary.json").is_file()
