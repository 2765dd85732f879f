"""Generated data sets: cached, resumable, shardable and byte-deterministic (issue 2).

Layout: `<paths.data_dir>/generated-<key>/` where the key hashes everything that decides the
contents: the simulator config, the generator-relevant dataset config, the seed, the record
format and the source of the packages that make the data (domain, simulation), so a change of
the world's code never serves stale data. Inside, one shard file per chunk of consecutive
assemblies of one size, `A<size>/<start>-<stop>.jsonl.gz`, plus a `<start>-<stop>.seconds.json`
timing sidecar (timings vary between runs, so they stay out of the data bytes).

Assembly i of size n is drawn from its own generator seeded by (seed, n, i), so the data do not
depend on chunking, sharding or the number of workers. A chunk is written atomically once done;
a rerun skips finished chunks (resume), and `dataset.shard=i dataset.num_shards=n` makes a run
generate only every n-th chunk from the i-th, so several processes or machines can share the
work; any later unsharded run (or :func:`load_generated`) finds them and only fills gaps.
"""

from __future__ import annotations

import hashlib
import json
import logging
import multiprocessing as mp
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf
from tqdm import tqdm

from grace.data.atomic import write_text_atomic
from grace.data.shards import SHARD_SUFFIX, read_shard, write_shard
from grace.domain.sample import LabelledAssembly

log = logging.getLogger(__name__)

FORMAT_VERSION = 1
"""Bump when the record layout or the seeding scheme changes: it is part of the cache key."""

SOURCE_PACKAGES = ("domain", "simulation")
"""Packages under `grace/` whose source is hashed into the cache key."""

OPERATIONAL_KEYS = frozenset({"sizes", "shard", "num_shards", "workers", "chunk_size"})
"""Dataset keys that decide how much or how fast to generate, not what an assembly is."""


@dataclass(frozen=True)
class Chunk:
    """Assemblies `start`..`stop`-1 of size `size`: one shard file."""

    size: int
    start: int
    stop: int

    @property
    def stem(self) -> str:
        return f"A{self.size}/{self.start:06d}-{self.stop:06d}"

    def path(self, root: Path) -> Path:
        return root / f"{self.stem}{SHARD_SUFFIX}"

    def seconds_path(self, root: Path) -> Path:
        return root / f"{self.stem}.seconds.json"


@dataclass(frozen=True)
class Generation:
    """What a generation run left behind: where, and whether every planned chunk exists."""

    path: Path
    chunks: list[Chunk]
    generated: int
    missing: int

    @property
    def complete(self) -> bool:
        return self.missing == 0


def requested_sizes(dataset: DictConfig | Mapping) -> dict[int, int]:
    """`dataset.sizes` as {size: count}, sizes ascending (YAML or CLI keys may be strings)."""
    sizes = dataset.get("sizes")
    if not sizes:
        raise ValueError(
            "dataset.sizes is empty; fix: set it (e.g. scale=smoke) to a mapping size → count"
        )
    out = {int(k): int(v) for k, v in sizes.items()}
    bad = {k: v for k, v in out.items() if k < 1 or v < 0}
    if bad:
        raise ValueError(f"dataset.sizes has invalid entries {bad}; fix: sizes ≥ 1 and counts ≥ 0")
    return dict(sorted(out.items()))


def source_digest() -> str:
    """Hash of the Python source of :data:`SOURCE_PACKAGES` (file names and contents)."""
    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for package in SOURCE_PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            digest.update(str(path.relative_to(root)).encode("utf-8") + b"\0" + path.read_bytes())
    return digest.hexdigest()[:16]


def key_config(cfg: DictConfig) -> dict[str, Any]:
    """The config that decides the data set's contents (what the cache key hashes)."""
    dataset = OmegaConf.to_container(cfg.dataset, resolve=True)
    return {
        "format": FORMAT_VERSION,
        "source": source_digest(),
        "seed": int(cfg.seed),
        "simulator": OmegaConf.to_container(cfg.simulator, resolve=True),
        "dataset": {k: v for k, v in dataset.items() if k not in OPERATIONAL_KEYS},
    }


def dataset_dir(cfg: DictConfig) -> Path:
    """`<paths.data_dir>/generated-<key>`; the key is a hash of :func:`key_config`."""
    text = json.dumps(key_config(cfg), sort_keys=True, separators=(",", ":"))
    key = hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
    return Path(cfg.paths.data_dir).absolute() / f"{cfg.dataset.name}-{key}"


def plan(sizes: Mapping[int, int], chunk_size: int) -> list[Chunk]:
    """All chunks of a data set, sizes ascending, then by start index."""
    if chunk_size < 1:
        raise ValueError(f"dataset.chunk_size={chunk_size}; fix: use a positive chunk size")
    return [
        Chunk(size, start, min(start + chunk_size, count))
        for size, count in sorted(sizes.items())
        for start in range(0, count, chunk_size)
    ]


def assembly_rng(seed: int, size: int, index: int) -> np.random.Generator:
    """The generator of assembly `index` of size `size`: independent of chunks and shards."""
    return np.random.default_rng(np.random.SeedSequence([seed, size, index]))


def _sample(simulator: Any, seed: int, size: int, index: int) -> tuple[LabelledAssembly, float]:
    start = time.perf_counter()
    sample = simulator.sample(size, assembly_rng(seed, size, index))
    seconds = time.perf_counter() - start
    if not sample.assembly.name:
        sample.assembly.name = f"A{size}-{index:06d}"
    return sample, seconds


def _write_chunk(
    simulator: Any, seed: int, chunk: Chunk, root: Path, progress: tqdm | None = None
) -> int:
    samples, seconds = [], []
    for index in range(chunk.start, chunk.stop):
        sample, s = _sample(simulator, seed, chunk.size, index)
        samples.append(sample)
        seconds.append(s)
        if progress is not None:
            progress.update(1)
    # Sidecar first: a chunk file on disk always has its timings.
    write_text_atomic(chunk.seconds_path(root), json.dumps({"seconds": seconds}))
    write_shard(chunk.path(root), samples)
    return len(samples)


_worker_simulator: Any = None


def _init_worker(simulator_cfg: dict[str, Any]) -> None:
    global _worker_simulator
    _worker_simulator = instantiate(OmegaConf.create(simulator_cfg))


def _worker_chunk(args: tuple[int, Chunk, Path]) -> int:
    seed, chunk, root = args
    return _write_chunk(_worker_simulator, seed, chunk, root)


def _run(pending: list[Chunk], cfg: DictConfig, root: Path, workers: int) -> int:
    total = sum(c.stop - c.start for c in pending)
    seed = int(cfg.seed)
    simulator_cfg = OmegaConf.to_container(cfg.simulator, resolve=True)
    with tqdm(total=total, desc=f"generate {root.name}", unit="asm", dynamic_ncols=True) as bar:
        if workers <= 1 or len(pending) <= 1:
            simulator = instantiate(OmegaConf.create(simulator_cfg))
            return sum(_write_chunk(simulator, seed, c, root, bar) for c in pending)
        ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
        done = 0
        # Largest assemblies first, so no long chunk is left running alone at the end.
        jobs = [(seed, c, root) for c in sorted(pending, key=lambda c: -c.size)]
        with ctx.Pool(min(workers, len(pending)), _init_worker, (simulator_cfg,)) as pool:
            for n in pool.imap_unordered(_worker_chunk, jobs):
                bar.update(n)
                done += n
        return done


def generate(
    cfg: DictConfig, shard: int | None = None, num_shards: int | None = None
) -> Generation:
    """Generate this run's share of the missing chunks of the data set `cfg` describes.

    `shard`/`num_shards` default to `dataset.shard`/`dataset.num_shards`. Returns where the data
    set lives and how many of its chunks are still missing (other shards' share).
    """
    dataset = cfg.dataset
    shard = int(dataset.get("shard", 0) if shard is None else shard)
    num_shards = int(dataset.get("num_shards", 1) if num_shards is None else num_shards)
    if not 0 <= shard < num_shards:
        raise ValueError(
            f"dataset.shard={shard}, dataset.num_shards={num_shards}; fix: 0 ≤ shard < num_shards"
        )
    root = dataset_dir(cfg)
    chunks = plan(requested_sizes(dataset), int(dataset.chunk_size))
    manifest = root / "config.json"
    if not manifest.exists():
        write_text_atomic(manifest, json.dumps(key_config(cfg), sort_keys=True, indent=2) + "\n")
    mine = [
        c for k, c in enumerate(chunks) if k % num_shards == shard and not c.path(root).exists()
    ]
    workers = int(dataset.get("workers", 1))
    start = time.perf_counter()
    generated = _run(mine, cfg, root, workers) if mine else 0
    wall = time.perf_counter() - start
    missing = sum(not c.path(root).exists() for c in chunks)
    log.info(
        "%s: %d assemblies generated in %.1f s wall (%d workers); %d of %d chunks missing",
        root, generated, wall, workers, missing, len(chunks),
    )  # fmt: skip
    return Generation(root, chunks, generated, missing)


def read_chunks(root: Path, chunks: list[Chunk]) -> list[LabelledAssembly]:
    """The assemblies of `chunks` in order (size ascending, then index)."""
    return [sample for chunk in chunks for sample in read_shard(chunk.path(root))]


def seconds_per_assembly(root: Path, chunks: list[Chunk]) -> dict[int, float]:
    """Mean generation seconds per assembly by size, from the timing sidecars that exist."""
    by_size: dict[int, list[float]] = {}
    for chunk in chunks:
        path = chunk.seconds_path(root)
        if path.exists():
            by_size.setdefault(chunk.size, []).extend(json.loads(path.read_text())["seconds"])
    return {size: float(np.mean(s)) for size, s in sorted(by_size.items()) if s}


def load_generated(cfg: DictConfig) -> list[LabelledAssembly]:
    """Generate whatever is missing (all shards' share) and load the data set."""
    generation = generate(cfg, shard=0, num_shards=1)
    return read_chunks(generation.path, generation.chunks)
