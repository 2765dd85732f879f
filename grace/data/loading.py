"""`load_dataset(cfg)`: the one call train and experiment tasks use to get their assemblies.

- `dataset=generated`: generate what is missing, then load from the cache (grace.data.store).
- `dataset=raw dataset.path=...`: import a folder of raw assembly folders (SPEC §3) once and cache
  the import as shard files under `<paths.data_dir>/raw-<key>/`, the key hashing the folder's
  path and its files' names, sizes and modification times, so an edit re-imports.
Both return the assemblies ordered by size, then by index (generated) or folder path (raw);
`dataset.sizes` (size → count) selects the first `count` of each size (`null` = all, raw only).
"""

from __future__ import annotations

import hashlib
import json
import logging
from pathlib import Path

from omegaconf import DictConfig

from grace.data.atomic import write_text_atomic
from grace.data.raw_format import RAW_FILES, find_raw_folders, import_raw_folders
from grace.data.shards import SHARD_SUFFIX, read_shard, write_shard
from grace.data.store import load_generated, requested_sizes
from grace.domain.sample import LabelledAssembly

log = logging.getLogger(__name__)


def _raw_key(folders: list[Path]) -> str:
    digest = hashlib.sha256()
    for folder in folders:
        for name in RAW_FILES:
            path = folder / name
            stat = path.stat() if path.exists() else None
            entry = (
                str(path.absolute()),
                stat.st_size if stat else -1,
                stat.st_mtime_ns if stat else -1,
            )
            digest.update(repr(entry).encode("utf-8"))
    return digest.hexdigest()[:16]


def import_raw_tree(root: str | Path, cache: str | Path) -> list[LabelledAssembly]:
    """All raw assemblies under `root`, imported once and cached under `cache/raw-<key>/`."""
    folders = find_raw_folders(root)
    target = Path(cache).absolute() / f"raw-{_raw_key(folders)}"
    manifest = target / "manifest.json"
    if manifest.exists():
        sizes = json.loads(manifest.read_text())["sizes"]
        return [
            s
            for size in sorted(int(k) for k in sizes)
            for s in read_shard(target / f"A{size}{SHARD_SUFFIX}")
        ]
    samples = import_raw_folders(folders, root)  # raises before anything is written
    by_size: dict[int, list[LabelledAssembly]] = {}
    for sample in samples:
        by_size.setdefault(sample.size, []).append(sample)
    for size, group in by_size.items():
        write_shard(target / f"A{size}{SHARD_SUFFIX}", group)
    counts = {str(size): len(group) for size, group in sorted(by_size.items())}
    write_text_atomic(
        manifest, json.dumps({"root": str(Path(root).absolute()), "sizes": counts}, indent=2) + "\n"
    )
    log.info("imported %d raw assemblies from %s into %s", len(samples), root, target)
    return [s for size in sorted(by_size) for s in by_size[size]]


def _select(samples: list[LabelledAssembly], dataset: DictConfig) -> list[LabelledAssembly]:
    if dataset.get("sizes") is None:
        return samples
    wanted = requested_sizes(dataset)
    out = []
    for size, count in wanted.items():
        group = [s for s in samples if s.size == size]
        if len(group) < count:
            log.warning(
                "raw data set has %d assemblies of size %d, %d requested", len(group), size, count
            )
        out.extend(group[:count])
    return out


def load_dataset(cfg: DictConfig) -> list[LabelledAssembly]:
    """The assemblies `cfg.dataset` describes (see module docstring)."""
    kind = cfg.dataset.name
    if kind == "generated":
        return load_generated(cfg)
    if kind == "raw":
        path = cfg.dataset.get("path")
        if not path:
            raise ValueError(
                "dataset=raw needs dataset.path; fix: add dataset.path=/folder/of/assembly/folders"
            )
        return _select(import_raw_tree(path, cfg.paths.data_dir), cfg.dataset)
    raise ValueError(f"dataset.name={kind!r} is unknown; fix: use dataset=generated or dataset=raw")
