"""Shared fixtures.

`cfg_factory(*overrides)` composes `conf/config.yaml` with Hydra's compose API exactly as
`python -m grace <overrides>` would, except that `paths.output_dir` and `paths.data_dir` point
into the test's `tmp_path` (`tmp_path/output`, `tmp_path/data`) and HydraConfig is set, so
`${hydra:...}` interpolations and `HydraConfig.get()` work inside task code. Example:

    def test_something(cfg_factory):
        cfg = cfg_factory("task=generate", "scale=smoke", "threads=1")
        run(cfg)  # call the task function directly

Overrides use the command-line syntax, including `~group` to drop a default that a test does not
need. `samples` are small labelled assemblies (FakeSimulator rows plus a frame with a
bracket) for the model and training tests. `fake_simulator` is a config for
:class:`FakeSimulator`, a tiny deterministic stand-in with the real simulator's interface
(generate / label / sample and the same `info` keys), for tests of the layers above the
simulator that must not depend on its speed or tuning; tests get an instance with
`hydra.utils.instantiate(fake_simulator)`. Never `import conftest`: every test folder's
conftest shares that module name, so this module is also registered under the stable
name `grace_tests_conftest`, which the config's `_target_` uses (worker processes inherit it).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import numpy as np
import pytest
import torch
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.core.hydra_config import HydraConfig
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf, open_dict

from grace import CONF_DIR
from grace.cli.schemas import register_schemas
from grace.domain.assembly import Assembly, Part, PartType, canonical_order, planar_pose
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.planning.plans import Plan, PlannedOrder, StepVerdicts
from grace.simulation.cell_config import CellConfig, typed

if int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")) > 1:
    # One intra-op thread per worker (and per process a test starts): two workers of two
    # threads each on two cores spin-wait for each other, which made tests that call torch
    # directly (not through a task's `threads`) up to 10x slower than alone.
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    torch.set_num_threads(1)

MODULE_ALIAS = "grace_tests_conftest"
sys.modules[MODULE_ALIAS] = sys.modules[__name__]


@pytest.fixture
def cfg_factory(tmp_path: Path) -> Callable[..., DictConfig]:
    """Compose the project config with command-line style overrides; outputs go to tmp_path.
    Under pytest-xdist (one worker per core) a run gets one thread unless a test sets `threads`:
    two workers of two threads each on two cores spend their time waiting for each other."""

    def make(*overrides: str) -> DictConfig:
        out, data = tmp_path / "output", tmp_path / "data"
        shared_cores = "PYTEST_XDIST_WORKER" in os.environ
        if shared_cores and not any(o.startswith("threads=") for o in overrides):
            overrides = ("threads=1", *overrides)
        register_schemas()
        GlobalHydra.instance().clear()
        with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
            cfg = compose(
                config_name="config",
                overrides=[f"paths.output_dir={out}", f"paths.data_dir={data}", *overrides],
                return_hydra_config=True,
            )
        with open_dict(cfg):
            cfg.hydra.runtime.output_dir = str(out)
            cfg.hydra.job.num = 0
        HydraConfig.instance().set_config(cfg)
        with open_dict(cfg):
            del cfg["hydra"]
        return cfg

    return make


class FakeSimulator:
    """Profiles in a row; a part needs a placed neighbour in the row (fixation).

    Robot rules, decided by the geometry so `label` needs no randomness: a 300 mm profile cannot
    be placed once a part two places away is (a non-local block; two such profiles make the
    assembly infeasible by collision), and the first part is out of reach when it lies at
    y = 30 (reach). `delay` seconds of sleep per sample stand for a real simulator's work.
    """

    def __init__(self, spacing: float = 250.0, delay: float = 0.0) -> None:
        self.spacing = spacing
        self.delay = delay

    def generate(self, n_parts: int, rng: np.random.Generator) -> Assembly:
        parts = [
            Part(
                f"part_{i}",
                PartType.PROFILE_300 if rng.random() < 0.4 else PartType.PROFILE_200,
                planar_pose(i * self.spacing, 10.0 * int(rng.integers(0, 4)), 1),
            )
            for i in range(n_parts)
        ]
        return Assembly(tuple(canonical_order(parts)))

    @staticmethod
    def _rules(assembly: Assembly, robot: bool) -> Callable[[int, int], bool]:
        long = [p.type is PartType.PROFILE_300 for p in assembly.parts]
        out_of_reach = robot and assembly.parts[0].xy[1] == 30.0

        def can_place(state: int, part: int) -> bool:
            left, right = (
                bool(state >> (part - 1) & 1) if part else False,
                bool(state >> (part + 1) & 1),
            )
            if robot and part == 0 and out_of_reach:
                return False
            if (
                robot
                and long[part]
                and any(0 <= q < len(long) and state >> q & 1 for q in (part - 2, part + 2))
            ):
                return False
            return state == 0 or left or right

        return can_place

    def label(self, assembly: Assembly) -> LabelledAssembly:
        start = time.perf_counter()
        truth = GroundTruth.explore(assembly.n_parts, self._rules(assembly, robot=True))
        fixation = GroundTruth.explore(assembly.n_parts, self._rules(assembly, robot=False))
        cause = None
        if not truth.feasible:
            cause = "reach" if assembly.parts[0].xy[1] == 30.0 else "collision"
        pruned = truth.feasible and truth.n_orders() < fixation.n_orders()
        info = {
            "cause": cause,
            "robot_pruned": pruned,
            "nonlocal_block": pruned,
            "orders": truth.n_orders(),
            "seconds": time.perf_counter() - start,
        }
        return LabelledAssembly(assembly, truth, info)

    def sample(self, n_parts: int, rng: np.random.Generator) -> LabelledAssembly:
        time.sleep(self.delay)
        return self.label(self.generate(n_parts, rng))


@pytest.fixture
def fake_simulator() -> DictConfig:
    """A `simulator` config that instantiates :class:`FakeSimulator`."""
    return OmegaConf.create({"_target_": f"{MODULE_ALIAS}.FakeSimulator", "spacing": 250.0})


@pytest.fixture(scope="session")
def default_cell() -> CellConfig:
    """The default world's cell (grace/conf/simulator/cell/iiwa14_dual.yaml), typed as the
    simulator types it: what `model.graph.cell` receives from `${simulator.cell}`."""
    values = OmegaConf.load(CONF_DIR / "simulator" / "cell" / "iiwa14_dual.yaml")
    del values["defaults"]
    return typed(CellConfig, values, "cell")


def bracket_frame() -> LabelledAssembly:
    """Bar, post and a bracket in their corner; the bracket needs both profiles placed."""
    assembly = Assembly(
        (
            Part("bar", PartType.PROFILE_300, planar_pose(0.0, 0.0, 1)),
            Part("post", PartType.PROFILE_200, planar_pose(0.0, 120.0)),
            Part("bracket", PartType.BRACKET, planar_pose(20.0, 20.0)),
        )
    )
    truth = GroundTruth.explore(3, lambda state, part: part != 2 or state == 0b011)
    return LabelledAssembly(assembly, truth)


def connected(touch: np.ndarray) -> bool:
    """Whether the contact graph `touch` (N×N booleans, e.g. joints.touching) is connected."""
    seen, todo = {0}, [0]
    while todo:
        for j in np.flatnonzero(touch[todo.pop()]):
            if int(j) not in seen:
                seen.add(int(j))
                todo.append(int(j))
    return len(seen) == len(touch)


@pytest.fixture
def samples(fake_simulator) -> list[LabelledAssembly]:
    """The bracket frame, five feasible rows of 3–6 parts and one infeasible row."""
    simulator = instantiate(fake_simulator)
    rng = np.random.default_rng(0)
    drawn = [simulator.sample(n, rng) for n in (3, 4, 5, 6) * 8]
    feasible = [s for s in drawn if s.truth.feasible and s.size > 3][:5]
    infeasible = [s for s in drawn if not s.truth.feasible][:1]
    return [bracket_frame(), *feasible, *infeasible]


def _size_entry(seq: float, step: float = 1.0, **fields: object) -> dict:
    """A results.json entry of one test size: sequence and step AUC (std 0.01 and 0), eight
    feasible test assemblies, and any other `fields`."""
    return {
        "folds": 4,
        "assemblies": 8,
        "forward_passes": 100,
        "step_auc": {"mean": step, "std": 0.0},
        "seq_auc": {"mean": seq, "std": 0.01},
        "no_sequence": 0,
        "feasibility": {"confusion": {"tp": 8, "fp": 0, "tn": 0, "fn": 0}},
        **fields,
    }


@pytest.fixture
def size_entry() -> Callable[..., dict]:
    """`size_entry(seq, step=1.0, **fields)`: a results.json entry of one test size, sequence and
    step AUC (std 0.01 and 0), eight feasible test assemblies, and any other `fields`."""
    return _size_entry


@pytest.fixture
def results_run() -> Callable[..., Path]:
    """`write(folder, protocol, train, test, entry, overrides=(), seed=0, baselines=None)`:
    a run folder holding a results.json whose every test size has `entry` (a dict, or a
    function of the size) and `.hydra/overrides.yaml`; baselines: name -> entry."""

    def write(
        folder: Path,
        protocol: str,
        train: list[int],
        test: list[int],
        entry: dict | Callable[[int], dict],
        overrides: Sequence[str] = (),
        seed: int = 0,
        baselines: dict[str, dict] | None = None,
    ) -> Path:
        of = entry if callable(entry) else (lambda size: entry)
        results = {
            "protocol": protocol,
            "train_sizes": train,
            "test_sizes": test,
            "folds": 4,
            "per_size": {str(s): of(s) for s in test},
            "baselines": {
                name: {"per_size": {str(s): e for s in test}}
                for name, e in (baselines or {}).items()
            },
            "seconds": 1.0,
            "seconds_by_stage": {"load": 0.1, "train": [0.4], "evaluate": [0.5]},
            "run": {"model": "grace_geometric", "seed": seed, "data_seed": 0,
                    "overrides": list(overrides)},
        }  # fmt: skip
        (folder / ".hydra").mkdir(parents=True)
        (folder / "results.json").write_text(json.dumps(results, indent=2))
        (folder / ".hydra" / "overrides.yaml").write_text(
            "".join(f"- {o}\n" for o in overrides) or "[]\n"
        )
        return folder

    return write


def _unlock(folder: Path) -> None:
    if os.geteuid() == 0:
        subprocess.run(["chattr", "-i", str(folder)], capture_output=True, check=False)
    else:
        folder.chmod(0o755)


@pytest.fixture
def lock_folder() -> Iterator[Callable[[Path], Callable[[], None]]]:
    """`lock(folder)` makes `folder` refuse new files, for any user: mode 555, or for root (whom
    modes do not stop) the immutable attribute (chattr +i), and returns what undoes it (the fix
    a test follows; undone at the end anyway). Skips the test where neither stops a write."""
    locked: list[Path] = []

    def lock(folder: Path) -> Callable[[], None]:
        if os.geteuid() == 0 and shutil.which("chattr"):
            subprocess.run(["chattr", "+i", str(folder)], capture_output=True, check=False)
        elif os.geteuid() != 0:
            folder.chmod(0o555)
        locked.append(folder)
        try:
            with tempfile.TemporaryFile(dir=folder):
                pass
        except OSError:
            return lambda: _unlock(folder)
        pytest.skip("no way to make a folder refuse new files here (root without chattr +i)")

    yield lock
    for folder in locked:
        _unlock(folder)


def accepted(can_place: Callable[[int, int], bool], order: Sequence[int]) -> bool:
    """Whether every step of `order` passes `can_place(state, part)` (e.g. FakeSimulator's
    rules)."""
    state = 0
    for part in order:
        if not can_place(state, part):
            return False
        state |= 1 << part
    return True


def _verdicts(can_place: Callable[[int, int], bool], order: Sequence[int]) -> StepVerdicts:
    """`order`'s verdicts up to its first refused step, as a plan holds them."""
    verdicts, state = [], 0
    for part in order:
        verdicts.append(bool(can_place(state, part)))
        if not verdicts[-1]:
            step = len(verdicts) - 1
            return StepVerdicts(False, tuple(verdicts), step, "collision", (), "refused")
        state |= 1 << part
    return StepVerdicts(True, tuple(verdicts))


def fake_plan(
    assembly: Assembly,
    can_place: Callable[[int, int], bool],
    orders: Sequence[Sequence[int]],
    outcome: str = "verified",
) -> Plan:
    """A checked plan (grace/planning/plans.py) listing `orders`, each checked step by step with
    `can_place` and kept with its refused step if it has one: what self-training's labels are
    built from, without a simulator."""
    listed = tuple(
        PlannedOrder(
            rank, tuple(o), ("p",) * len(o), 0.5, (0.5,) * len(o), _verdicts(can_place, o), None
        )
        for rank, o in enumerate(orders, 1)
    )
    return Plan(assembly.name, assembly.n_parts, {"name": "fake"}, outcome, listed, 0.1)
