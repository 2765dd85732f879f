"""`python -m grace` (task=experiment): cross-validated training, planning and evaluation.

For each fold of the chosen protocol (SPEC §8) it trains one model, plans every test assembly
with Algorithm 1 over distinct states and computes the SPEC §7 metrics per test size, for GRACE
and for the baselines on the same test assemblies. Writes results.json, results.md,
pr_curves.png and p_at_k.png into the run folder and returns the mean sequence AUC over the test
sizes (the sweep objective).
"""

from __future__ import annotations

import logging
import math
import time
from pathlib import Path

import numpy as np
from hydra.core.hydra_config import HydraConfig
from hydra.utils import get_method
from omegaconf import DictConfig, OmegaConf

from grace.evaluation.baselines import BASELINES
from grace.evaluation.evaluate import evaluate_by_size
from grace.evaluation.protocols import Fold, make_folds, protocol_sizes
from grace.evaluation.report import aggregate, write_results
from grace.planning.sequences import Scorer
from grace.visualisation.plots import p_at_k_bars, pr_curves

log = logging.getLogger(__name__)


def _overrides() -> list[str]:
    return list(HydraConfig.get().overrides.task) if HydraConfig.initialized() else []


def _mean_curves(per_fold: list[dict[int, dict]]) -> dict[str, dict]:
    """Fold-mean PR curve per size (all folds share the λ grid, so points align)."""
    out = {}
    for size in sorted({s for fold in per_fold for s in fold}):
        curves = [f[size]["curve"] for f in per_fold if size in f and f[size]["curve"]["recall"]]
        if curves:
            out[str(size)] = {
                key: np.mean([c[key] for c in curves], axis=0).tolist()
                for key in ("recall", "precision")
            }
    return out


def _folds(cfg: DictConfig, sizes: list[int]) -> tuple[list[int], list[int], list[Fold]]:
    proto = cfg.protocol
    train_sizes, test_sizes = protocol_sizes(
        proto.name,
        sizes,
        OmegaConf.to_object(proto.train_sizes) if proto.train_sizes is not None else None,
        OmegaConf.to_object(proto.test_sizes) if proto.test_sizes is not None else None,
        list(proto.train_exclude),
        list(proto.test_exclude),
    )
    folds = make_folds(sizes, train_sizes, test_sizes, proto.folds, proto.val_fraction, proto.seed)
    return train_sizes, test_sizes, folds


def _policies(cfg: DictConfig, module: object, fold: Fold) -> dict[str, Scorer]:
    """GRACE from the trained module plus every baseline of `task.baselines`, seeded per fold."""
    unknown = sorted(set(cfg.task.baselines) - set(BASELINES))
    if unknown:
        raise ValueError(f"task.baselines: unknown {unknown}; choose from {sorted(BASELINES)}")
    policies = {"GRACE": get_method(cfg.task.scorer)(module)}
    policies.update({b: BASELINES[b](cfg.seed + fold.index) for b in cfg.task.baselines})
    return policies


def run(cfg: DictConfig) -> float:
    """Run the experiment of `cfg.protocol`; return the mean sequence AUC of GRACE."""
    start = time.perf_counter()
    out_dir = Path(cfg.paths.output_dir)
    data = get_method(cfg.task.loader)(cfg)
    train_sizes, test_sizes, folds = _folds(cfg, [sample.size for sample in data])
    fit = get_method(cfg.task.fit)
    ks = [int(k) for k in cfg.task.ks]
    per_fold: dict[str, list[dict[int, dict]]] = {}
    load_s, train_s, evaluate_s = time.perf_counter() - start, [], []
    for fold in folds:
        log.info(
            "fold %d: train %d, val %d, test %d assemblies",
            *(fold.index, len(fold.train), len(fold.val), len(fold.test)),
        )
        tick = time.perf_counter()
        train, val = [data[i] for i in fold.train], [data[i] for i in fold.val]
        module = fit(cfg, train, val, out_dir / f"fold_{fold.index}")
        train_s.append(time.perf_counter() - tick)
        tick = time.perf_counter()
        test = [data[i] for i in fold.test]
        for name, scorer in _policies(cfg, module, fold).items():
            per_fold.setdefault(name, []).append(
                evaluate_by_size(scorer, test, ks, cfg.task.threshold)
            )
        evaluate_s.append(time.perf_counter() - tick)
    per_size = aggregate(per_fold["GRACE"])
    baselines = {b: {"per_size": aggregate(per_fold[b])} for b in cfg.task.baselines}
    results = {
        "protocol": cfg.protocol.name,
        "train_sizes": train_sizes,
        "test_sizes": test_sizes,
        "folds": len(folds),
        "per_size": per_size,
        "baselines": baselines,
        "seconds": time.perf_counter() - start,
        "seconds_by_stage": {"load": load_s, "train": train_s, "evaluate": evaluate_s},
        "run": {
            "model": OmegaConf.select(cfg, "model.name"),
            "seed": cfg.seed,
            "overrides": _overrides(),
        },
    }
    write_results(results, out_dir)
    pr_curves({name: _mean_curves(f) for name, f in per_fold.items()}, out_dir / "pr_curves.png")
    p_at_k_bars(
        {"GRACE": per_size, **{b: baselines[b]["per_size"] for b in baselines}},
        out_dir / "p_at_k.png",
    )
    seq = [entry["seq_auc"]["mean"] for entry in per_size.values() if "seq_auc" in entry]
    objective = float(np.mean(seq)) if seq else math.nan
    log.info("mean sequence AUC %.4f, results in %s", objective, out_dir)
    return objective
