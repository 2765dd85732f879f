"""Generated data sets: cached, resumable, shardable, checked and byte-deterministic.

:class:`GeneratedSource` (`dataset=generated`) is the data source. Layout:
`<data_dir>/generated-<key>/` where the key hashes everything that decides the contents: the
simulator config, the seed, the record format and the source of the packages that make the data
(domain, simulation), so a change of the world's code never serves stale data. Inside, one shard
file per chunk of consecutive assemblies of one size, `A<size>/<start>-<stop>.jsonl.gz`, and its
manifest `<start>-<stop>.json`, written atomically after it: the shard's record count and SHA-256
and the generation time of each assembly (timings vary between runs, so they stay out of the
data bytes). A chunk exists once its manifest does.

Assembly i of size n is drawn from its own generator seeded by (seed, n, i), so the data do not
depend on chunking, sharding or the number of workers or processes. A rerun skips finished chunks
(resume), and `dataset.shard=i dataset.num_shards=n` makes a run generate only every n-th chunk
from the i-th; any later unsharded run (or :meth:`GeneratedSource.load`) finds them and only fills
gaps. Every run checks each chunk against its manifest first: an empty, short, truncated or
altered shard or manifest is reported in one line naming the file, moved to `<key>/corrupt/` and
generated again, as is a chunk whose records, read, are not those of the chunk although they
match the manifest's checksum (both rewritten). What a run cannot repair (a folder where a file
of the data set belongs, a folder it must write into that is a file or refuses new files) stops
it in one line with the fix before anything is written (:func:`survey`; the command line checks
it before the run starts). Processes generating one data set at once share its chunks through
claim files (grace/data/claims.py) and wait for each other's, naming in the log each claim waited
for. docs/operations.md, "Cache integrity".
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import logging
import multiprocessing as mp
import os
import signal
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from hydra.utils import instantiate
from omegaconf import OmegaConf
from tqdm import tqdm

from grace.data import claims
from grace.data.atomic import write_json_atomic, write_text_atomic
from grace.data.distinct import distinct_from
from grace.data.folders import obstacle
from grace.data.shards import (
    SHARD_SUFFIX,
    ShardError,
    ShardInfo,
    check_shard,
    read_shard,
    write_shard,
)
from grace.domain.assembly import MIN_PARTS
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError

log = logging.getLogger(__name__)

FORMAT_VERSION = 2
"""Bump when the record layout, the seeding scheme or the files of a chunk change: it is part of
the cache key. 2: a checked manifest per chunk replaces the timing sidecar."""

CLAIM_POLL_SECONDS = 0.5
"""How often a run waiting for chunks that other processes generate looks again."""

SOURCE_PACKAGES = ("domain", "simulation")
"""Packages under `grace/` whose source is hashed into the cache key."""


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

    def manifest_path(self, root: Path) -> Path:
        return root / f"{self.stem}.json"

    def claim_path(self, root: Path) -> Path:
        return root / f"{self.stem}.claim"

    @property
    def count(self) -> int:
        return self.stop - self.start


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


def requested_sizes(sizes: Mapping[Any, Any] | None) -> dict[int, int]:
    """`dataset.sizes` as {size: count}, sizes ascending (YAML or CLI keys may be strings)."""
    if sizes and not isinstance(sizes, Mapping):
        raise UserError(
            f"dataset.sizes={sizes!r} is not a mapping size → count; "
            "fix: e.g. dataset.sizes={3: 8, 4: 8} (quoted for the shell)"
        )
    if not sizes:
        raise UserError(
            "dataset.sizes is empty; fix: set it (e.g. scale=smoke) to a mapping size → count"
        )
    try:
        out = {int(k): int(v) for k, v in sizes.items()}
    except (TypeError, ValueError):
        raise UserError(
            f"dataset.sizes={dict(sizes)} is not a mapping of integers; "
            'fix: e.g. dataset.sizes="{3: 8, 4: 8}"'
        ) from None
    bad = {k: v for k, v in out.items() if k < 1 or v < 1}
    if bad:
        raise UserError(f"dataset.sizes has invalid entries {bad}; fix: sizes ≥ 1 and counts ≥ 1")
    return dict(sorted(out.items()))


def source_digest() -> str:
    """Hash of the Python source of :data:`SOURCE_PACKAGES` (file names and contents)."""
    root = Path(__file__).resolve().parents[1]
    digest = hashlib.sha256()
    for package in SOURCE_PACKAGES:
        for path in sorted((root / package).rglob("*.py")):
            digest.update(str(path.relative_to(root)).encode("utf-8") + b"\0" + path.read_bytes())
    return digest.hexdigest()[:16]


def plan(sizes: Mapping[int, int], chunk_size: int) -> list[Chunk]:
    """All chunks of a data set, sizes ascending, then by start index."""
    if chunk_size < 1:
        raise UserError(f"dataset.chunk_size={chunk_size}; fix: use a positive chunk size")
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


def _generate_chunk(
    simulator: Any, seed: int, chunk: Chunk, root: Path, progress: tqdm | None = None
) -> int | None:
    """Generate and write `chunk` unless another live process holds its claim (None then).

    0 if the chunk turned out done meanwhile. The shard goes first, its manifest last: a chunk
    whose manifest exists is complete."""
    claim = chunk.claim_path(root)
    if not claims.claim(claim):
        return None
    try:
        if chunk.manifest_path(root).exists():
            return 0
        samples, seconds = [], []
        for index in range(chunk.start, chunk.stop):
            _stop_if_orphaned()
            sample, s = _sample(simulator, seed, chunk.size, index)
            samples.append(sample)
            seconds.append(s)
            claims.touch(claim)
            if progress is not None:
                progress.update(1)
        _stop_if_orphaned()
        info = write_shard(chunk.path(root), samples)
        write_json_atomic(chunk.manifest_path(root), {"shard": info.to_json(), "seconds": seconds})
        return len(samples)
    finally:
        claims.release(claim)


def _read_manifest(chunk: Chunk, root: Path) -> dict[str, Any]:
    """The manifest of a chunk, checked for the chunk's record count; ShardError if unreadable."""
    path = chunk.manifest_path(root)
    try:
        node = json.loads(path.read_bytes())
        info = ShardInfo.from_json(node["shard"])
        seconds = [float(t) for t in node["seconds"]]
    except OSError as e:
        raise ShardError(f"{path}: manifest unreadable ({e.strerror})") from None
    except (ValueError, KeyError, TypeError) as e:
        raise ShardError(f"{path}: manifest unreadable ({type(e).__name__}: {e})") from None
    if info.records != chunk.count or len(seconds) != chunk.count:
        raise ShardError(
            f"{path}: manifest records {info.records} assemblies and {len(seconds)} timings, "
            f"its chunk holds {chunk.count}"
        )
    return {"shard": info, "seconds": seconds}


def _check_chunk(chunk: Chunk, root: Path) -> bool:
    """Whether `chunk` exists (False: not generated yet); ShardError if it is corrupted."""
    if not chunk.manifest_path(root).exists():
        return False
    check_shard(chunk.path(root), _read_manifest(chunk, root)["shard"])
    return True


def read_chunk(chunk: Chunk, root: Path) -> list[LabelledAssembly]:
    """The assemblies of `chunk`, checked against its manifest (checksum, record count) and
    the chunk (their size); ShardError naming the file if they differ."""
    path = chunk.path(root)
    samples = read_shard(path, _read_manifest(chunk, root)["shard"])
    sizes = sorted({s.size for s in samples} - {chunk.size})
    if sizes:
        raise ShardError(
            f"{path}: shard holds assemblies of size {sizes}, its chunk is A{chunk.size}"
        )
    return samples


def _corrupt_folder(chunk: Chunk, root: Path) -> Path:
    """Where the files of a damaged `chunk` are set aside."""
    return root / "corrupt" / chunk.path(root).relative_to(root).parent


def _set_aside(chunk: Chunk, root: Path, error: ShardError) -> None:
    """Move a corrupted chunk's files to `<root>/corrupt/` (kept for inspection) and say so."""
    stamp = time.strftime("%Y%m%d-%H%M%S")
    where = _corrupt_folder(chunk, root)
    for path in (chunk.path(root), chunk.manifest_path(root)):
        try:
            where.mkdir(parents=True, exist_ok=True)
            os.replace(path, where / f"{stamp}-{path.name}")
        except FileNotFoundError:
            pass
        except OSError as e:  # found after the survey: a shard damaged while being read
            raise UserError(
                f"{error}; moving {path} to {where} failed ({e.strerror}); fix: make both "
                "writable and rerun, which moves it aside and generates it again"
            ) from None
    log.warning("%s; moved to %s, generating it again", error, where)


@dataclass(frozen=True)
class Survey:
    """What a run finds in a data set's folder before it writes anything."""

    done: set[Chunk]
    damaged: dict[Chunk, ShardError]


def survey(root: Path, chunks: list[Chunk], mine: list[Chunk]) -> Survey:
    """Which of `chunks` exist and which are damaged (set aside and generated again), when this
    run generates the missing ones of `mine`. What a run cannot repair is a UserError before it
    writes anything: a folder where a chunk's file belongs (a run moves no one's folder), a
    folder it must write into that is a file or refuses new files."""
    _refuse_folders_for_files(root, chunks)
    done, damaged = set(), {}
    for chunk in chunks:
        try:
            if _check_chunk(chunk, root):
                done.add(chunk)
        except ShardError as e:
            damaged[chunk] = e
    writes = {}
    for chunk in damaged:
        writes[chunk.path(root).parent] = "the damaged chunk's files (moved aside)"
        writes[_corrupt_folder(chunk, root)] = "the damaged chunk's files"
    for chunk in mine:
        if chunk not in done:
            writes.setdefault(chunk.path(root).parent, "the chunk's claim, shard and manifest")
    if not (root / "config.json").exists():
        writes[root] = "config.json"
    _refuse_unwritable(writes)
    return Survey(done, damaged)


def _refuse_folders_for_files(root: Path, chunks: list[Chunk]) -> None:
    """A UserError naming the first folder found where a chunk's shard, manifest or claim file
    belongs: left there on purpose, it is not a damaged chunk to move aside."""
    folders = [
        path
        for chunk in chunks
        for path in (chunk.path(root), chunk.manifest_path(root), chunk.claim_path(root))
        if path.is_dir()
    ]
    if folders:
        more = f" (and {len(folders) - 1} more such folders)" if len(folders) > 1 else ""
        raise UserError(
            f"{folders[0]} is a folder where a file of the data set belongs{more}; fix: move it "
            "away or delete it: its chunk is then generated again"
        )


def _refuse_unwritable(writes: dict[Path, str]) -> None:
    """A UserError for the first folder of `writes` (folder → what this run writes there) that
    is a file, lies under one, or refuses new files (grace/data/folders.py)."""
    for folder, what in writes.items():
        found = obstacle(folder)
        if found is None:
            continue
        if found.is_file:
            raise UserError(
                f"{found.path} is a file where a folder of the data set belongs ({folder}: "
                f"{what}); fix: move it away or delete it: the run makes the folder"
            )
        where = "there" if found.path == folder else f"in {folder}"
        raise UserError(
            f"{found.path} is not writable ({found.reason}), and this run writes {what} {where}; "
            f"fix: make it writable (chmod u+w {found.path}), or set paths.data_dir (or "
            "GRACE_DATA_DIR) to another folder"
        )


_worker_simulator: Any = None
_worker_parent: int | None = None


def _stop_if_orphaned() -> None:
    """In a generation worker whose parent died (even by SIGKILL, which it cannot pass on):
    exit before writing anything more."""
    if _worker_parent is not None and os.getppid() != _worker_parent:
        os._exit(1)


def build_simulator(simulator_cfg: Mapping[str, Any]) -> Any:
    """The simulator a config describes (`_target_` and its arguments)."""
    return instantiate(OmegaConf.create(dict(simulator_cfg)))


def _init_worker(simulator_cfg: dict[str, Any], parent: int) -> None:
    global _worker_simulator, _worker_parent
    # The parent stops the pool on Ctrl-C or SIGTERM (Pool.terminate sends SIGTERM): workers
    # ignore the terminal's SIGINT and die on SIGTERM whatever handler they inherited.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _worker_parent = parent
    _worker_simulator = build_simulator(simulator_cfg)


def _worker_chunk(args: tuple[int, Chunk, Path]) -> tuple[Chunk, int | None]:
    seed, chunk, root = args
    return chunk, _generate_chunk(_worker_simulator, seed, chunk, root)


def _run(
    pending: list[Chunk], simulator_cfg: dict[str, Any], seed: int, root: Path, workers: int
) -> int:
    """Generate the `pending` chunks: those another process claims are left to it, and waited
    for (or taken over if their owner dies). Returns the assemblies generated here."""
    # Built here first, so a bad simulator config fails once, in this process (a pool would
    # restart workers whose initializer fails, forever).
    simulator = build_simulator(simulator_cfg)
    # Largest assemblies first, so no long chunk is left running alone at the end.
    pending = sorted(pending, key=lambda c: -c.size)
    total = sum(c.count for c in pending)
    generated, others = 0, 0
    announced: set[Chunk] = set()
    pool = None
    if workers > 1 and len(pending) > 1:
        ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
        init = (simulator_cfg, os.getpid())
        pool = ctx.Pool(min(workers, len(pending)), _init_worker, init)
    # Leaving the block for any reason (an error, Ctrl-C, SIGTERM) terminates the workers;
    # shards and manifests are written atomically, so none is left half-written.
    with (
        pool or contextlib.nullcontext(),
        tqdm(total=total, desc=f"generate {root.name}", unit="asm", dynamic_ncols=True) as bar,
    ):
        while pending:
            if pool is None:
                results = [(c, _generate_chunk(simulator, seed, c, root, bar)) for c in pending]
            else:
                jobs = [(seed, c, root) for c in pending]
                results = list(pool.imap_unordered(_worker_chunk, jobs))
                bar.update(sum(n or 0 for _, n in results))
            generated += sum(n or 0 for _, n in results)
            busy = [c for c, n in results if n is None]
            pending = _wait_for_others(busy, root, announced)
            others += sum(c.count for c in busy if c not in pending)
            bar.update(sum(c.count for c in busy if c not in pending))
    if others:
        log.info("%d assemblies of %s were generated by other processes", others, root)
    return generated


def _wait_for_others(busy: list[Chunk], root: Path, announced: set[Chunk]) -> list[Chunk]:
    """Wait until a chunk that other processes claimed is done or free to take over; return
    those not done. Each chunk waited for is named once in the log (`announced`), with who holds
    it and when it is taken over."""
    while busy:
        left = [c for c in busy if not c.manifest_path(root).exists()]
        holders = {c: claims.live_holder(c.claim_path(root)) for c in left}
        if len(left) < len(busy) or not all(holders.values()):
            return left
        for chunk, holder in holders.items():
            if chunk not in announced:
                log.info("waiting for %s: %s", chunk.claim_path(root), holder)
                announced.add(chunk)
        time.sleep(CLAIM_POLL_SECONDS)
    return busy


@dataclass
class GeneratedSource:
    """A data set made by the simulator (`dataset=generated`), cached under `data_dir`.

    `simulator` is the simulator's config (`_target_` and arguments), not an instance: it is
    hashed into the cache key and instantiated in every worker process. `sizes` (size → count),
    `chunk_size`, `shard`, `num_shards` and `workers` decide how much is generated, where and
    how fast, never what an assembly is: they stay out of the key. With `distinct_from` (a
    data seed) :meth:`load` replaces every assembly whose canonical form is in the data set of
    that seed and the same sizes by the next draw of its size that is not (grace/data/distinct.py):
    the selection data set shares no assembly with the evaluation one.
    """

    simulator: dict[str, Any]
    seed: int
    data_dir: str
    sizes: dict[int, int] = field(default_factory=dict)
    chunk_size: int = 200
    shard: int = 0
    num_shards: int = 1
    workers: int = 1
    distinct_from: int | None = None

    def key_config(self) -> dict[str, Any]:
        """What decides the data set's contents (what the cache key hashes)."""
        return {
            "format": FORMAT_VERSION,
            "source": source_digest(),
            "seed": int(self.seed),
            "simulator": dict(self.simulator),
            "dataset": {"name": "generated"},
        }

    @property
    def path(self) -> Path:
        """`<data_dir>/generated-<key>`; the key is a hash of :meth:`key_config`."""
        text = json.dumps(self.key_config(), sort_keys=True, separators=(",", ":"))
        key = hashlib.sha256(text.encode("utf-8")).hexdigest()[:16]
        return Path(self.data_dir).absolute() / f"generated-{key}"

    def counts(self) -> dict[int, int]:
        """Assemblies per size that :meth:`load` returns, known before any is generated."""
        return requested_sizes(self.sizes)

    def check_sizes(self) -> None:
        """A UserError for sizes the simulator cannot build: beyond the cell's part slots
        (`simulator.cell.max_parts`, docs/world.md), or not a mapping of positive counts."""
        counts = self.counts()
        limit = self.simulator.get("cell", {}).get("max_parts")
        beyond = [size for size in counts if limit is not None and size > int(limit)]
        if beyond:
            raise UserError(
                f"dataset.sizes: sizes {beyond} exceed simulator.cell.max_parts={limit} (the "
                f"cell's part slots); fix: sizes from {MIN_PARTS} to {limit}"
            )

    def generate(self, shard: int | None = None, num_shards: int | None = None) -> Generation:
        """Generate this run's share of the missing chunks.

        `shard`/`num_shards` default to the source's own. Returns where the data set lives and
        how many of its chunks are still missing (other shards' share).
        """
        shard = self.shard if shard is None else shard
        num_shards = self.num_shards if num_shards is None else num_shards
        root = self.path
        chunks = plan(requested_sizes(self.sizes), self.chunk_size)
        found = survey(root, chunks, _share(chunks, shard, num_shards))
        manifest = root / "config.json"
        if not manifest.exists():
            text = json.dumps(self.key_config(), sort_keys=True, indent=2) + "\n"
            write_text_atomic(manifest, text)
        for chunk, error in found.damaged.items():
            _set_aside(chunk, root, error)
        mine = [c for c in _share(chunks, shard, num_shards) if c not in found.done]
        start = time.perf_counter()
        simulator = dict(self.simulator)
        generated = _run(mine, simulator, self.seed, root, self.workers) if mine else 0
        wall = time.perf_counter() - start
        missing = sum(not c.manifest_path(root).exists() for c in chunks)
        log.info(
            "%s: %d assemblies generated in %.1f s wall (%d workers); %d of %d chunks missing",
            root, generated, wall, self.workers, missing, len(chunks),
        )  # fmt: skip
        return Generation(root, chunks, generated, missing)

    def check_files(self) -> None:
        """A UserError for what in the data set's folder a run cannot repair (:func:`survey`):
        checked before any work, writing nothing."""
        chunks = plan(requested_sizes(self.sizes), self.chunk_size)
        survey(self.path, chunks, _share(chunks, self.shard, self.num_shards))

    def load(self) -> list[LabelledAssembly]:
        """Generate whatever is missing (all shards' share) and load the data set; with
        `distinct_from`, without the copies of that seed's data set (replaced by new draws)."""
        if self.distinct_from is None:
            return self.read(self.generate(shard=0, num_shards=1))
        plain = dataclasses.replace(self, distinct_from=None)
        reference = dataclasses.replace(plain, seed=self.distinct_from).load()

        def draws(sizes: dict[int, int]) -> list[LabelledAssembly]:
            return dataclasses.replace(plain, sizes=sizes).load()

        return distinct_from(draws, self.counts(), reference)

    def read(self, generation: Generation) -> list[LabelledAssembly]:
        """The assemblies of a complete `generation` in order (size ascending, then index). A
        chunk that matches its manifest's checksum but does not hold the chunk's records (shard
        and checksum both rewritten: only reading finds it) is set aside and generated again,
        like a chunk that fails its checksum."""
        root = generation.path
        read, damaged = {}, []
        for chunk in generation.chunks:
            try:
                read[chunk] = read_chunk(chunk, root)
            except ShardError as e:
                _set_aside(chunk, root, e)
                damaged.append(chunk)
        if damaged:
            self.generate(shard=0, num_shards=1)
            read.update((chunk, _read_or_refuse(chunk, root)) for chunk in damaged)
        return [sample for chunk in generation.chunks for sample in read[chunk]]


def _share(chunks: list[Chunk], shard: int, num_shards: int) -> list[Chunk]:
    """The chunks that run `shard` of `num_shards` generates: every num_shards-th from shard."""
    if not 0 <= shard < num_shards:
        raise UserError(
            f"dataset.shard={shard}, dataset.num_shards={num_shards}; fix: 0 ≤ shard < num_shards"
        )
    return chunks[shard::num_shards]


def _read_or_refuse(chunk: Chunk, root: Path) -> list[LabelledAssembly]:
    """:func:`read_chunk` of a chunk just generated again, its ShardError a UserError with the
    fix (it was set aside meanwhile by another process that found it damaged, or the disk)."""
    try:
        return read_chunk(chunk, root)
    except ShardError as e:
        raise UserError(f"{e}; fix: rerun, which moves it aside and generates it again") from None


def seconds_per_assembly(root: Path, chunks: list[Chunk]) -> dict[int, float]:
    """Mean generation seconds per assembly by size, from the manifests of the chunks that
    exist."""
    by_size: dict[int, list[float]] = {}
    for chunk in chunks:
        if chunk.manifest_path(root).exists():
            seconds = _read_manifest(chunk, root)["seconds"]
            by_size.setdefault(chunk.size, []).extend(seconds)
    return {size: float(np.mean(s)) for size, s in sorted(by_size.items()) if s}
