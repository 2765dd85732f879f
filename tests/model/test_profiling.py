import pytest
from omegaconf import open_dict

from grace.cli.fit import train_module
from grace.model.profiling import FORWARD, LOSS, STAGES, StageProfiler


def test_stages_add_up_to_the_profiled_epochs(cfg_factory, samples, tmp_path):
    """Two real epochs under Lightning: every stage of an epoch is found, the module's own
    forward and loss regions are timed inside the training step, and the stages (rest included)
    add up to the epochs' time by either clock."""
    cfg = cfg_factory(
        "trainer.max_epochs=2", "trainer.enable_progress_bar=false", "datamodule.batch_size=8"
    )
    with open_dict(cfg):
        cfg.trainer.profiler = {"_target_": "grace.model.profiling.StageProfiler"}
    profiler = train_module(cfg, samples, samples, tmp_path / "run").trainer.profiler
    assert isinstance(profiler, StageProfiler) and profiler.epochs == 2
    for wall, times in ((False, profiler.cpu), (True, profiler.wall)):
        stages = profiler.stages(wall)
        assert tuple(stages) == STAGES
        total = times["run_training_epoch"]
        assert sum(stages.values()) == pytest.approx(total / 2, rel=1e-9)
        for stage in ("batch assembly", "forward", "loss", "backward", "optimiser", "validation"):
            assert stages[stage] > 0, stage
    assert profiler.wall[FORWARD] > profiler.wall[LOSS] > 0
    assert "forward" in profiler.summary() and "epoch" in profiler.summary()


def test_actions_outside_an_epoch_are_not_counted():
    profiler = StageProfiler()
    with profiler.profile("[LightningModule]GraceModule.setup"):
        pass
    with profiler.profile("run_training_epoch"), profiler.profile(FORWARD):
        pass
    assert set(profiler.wall) == {"run_training_epoch", FORWARD} and profiler.epochs == 1
