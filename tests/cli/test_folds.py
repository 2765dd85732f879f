import numpy as np
from hydra.utils import instantiate

from grace.cli.folds import protocol_folds
from grace.domain.assembly import Assembly
from grace.domain.canonical import assembly_key, renumber_masks
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly


def _renumbered(sample: LabelledAssembly) -> LabelledAssembly:
    """The same assembly with its parts listed backwards."""
    order = np.arange(sample.size)[::-1]
    t = sample.truth
    states, placeable, completable = (
        renumber_masks(m, order) for m in (t.states, t.placeable, t.completable)
    )
    by = np.argsort(states)
    truth = GroundTruth(sample.size, states[by], placeable[by], completable[by])
    return LabelledAssembly(Assembly(tuple(sample.assembly.parts[i] for i in order)), truth)


def test_no_copy_of_a_test_assembly_is_trained_on(cfg_factory, fake_simulator):
    simulator = instantiate(fake_simulator)
    rng = np.random.default_rng(1)
    drawn = [simulator.sample(n, rng) for n in (3, 4) * 12]
    data = drawn + [drawn[i] for i in (0, 3)] + [_renumbered(drawn[i]) for i in (1, 2, 5, 8)]
    keys = [assembly_key(s) for s in data]
    assert len(set(keys)) < len(data) - 5  # the six copies (and whatever the draws repeat)
    cfg = cfg_factory("protocol.folds=3")
    for fold in protocol_folds(cfg, data)[2]:
        trained = {keys[i] for i in fold.train + fold.val}
        assert trained.isdisjoint(keys[i] for i in fold.test)
        assert {keys[i] for i in fold.train}.isdisjoint(keys[i] for i in fold.val)
