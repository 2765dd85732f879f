"""The original data set's raw folders as a data source (`dataset=raw`).

:class:`RawSource` imports a folder of raw assembly folders (docs/raw-format.md) once and caches
the import as shard files under `<data_dir>/raw-<key>/`, the key hashing the folders' paths and
their files' sizes and modification times, so an edit re-imports. Its `manifest.json`, written
after the shards, keeps each shard's record count and SHA-256: a cached shard that no longer
matches is refused in one line naming it and the fix (docs/operations.md, "Cache integrity"). Like
:class:`grace.data.store.GeneratedSource` (`dataset=generated`) its `load()` returns the
assemblies ordered by size, then by folder path; `sizes` (size → count) selects the first `count`
of each size (`null` = all of them).
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

from grace.data.atomic import write_json_atomic
from grace.data.raw_format import RAW_FILES, find_raw_folders, import_raw_folders
from grace.data.shards import SHARD_SUFFIX, ShardError, ShardInfo, read_shard, write_shard
from grace.data.store import FORMAT_VERSION, requested_sizes
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError

log = logging.getLogger(__name__)


def _raw_key(folders: list[Path]) -> str:
    digest = hashlib.sha256(f"format {FORMAT_VERSION}".encode())
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


def _cache_folder(folders: list[Path], cache: str | Path) -> Path:
    return Path(cache).absolute() / f"raw-{_raw_key(folders)}"


def _read_cache(target: Path, root: str | Path) -> list[LabelledAssembly]:
    """The cached import, every shard checked against the manifest; a mismatch is a UserError."""
    manifest = target / "manifest.json"
    fix = f"fix: delete {target} and rerun: the raw folders under {root} are imported again"
    try:
        shards = json.loads(manifest.read_bytes())["shards"]
        expected = {int(size): ShardInfo.from_json(node) for size, node in shards.items()}
    except OSError as e:  # a folder in its place, no permission to read
        raise UserError(f"{manifest}: cache manifest unreadable ({e.strerror}); {fix}") from None
    except (ValueError, KeyError, TypeError, AttributeError) as e:
        raise UserError(f"{manifest}: cache manifest unreadable ({e}); {fix}") from None
    samples = []
    for size, info in sorted(expected.items()):
        try:
            samples += read_shard(target / f"A{size}{SHARD_SUFFIX}", info)
        except ShardError as e:
            raise UserError(f"{e}; {fix}") from None
    return samples


def import_raw_tree(root: str | Path, cache: str | Path) -> list[LabelledAssembly]:
    """All raw assemblies under `root`, imported once and cached under `cache/raw-<key>/`."""
    folders = find_raw_folders(root)
    target = _cache_folder(folders, cache)
    manifest = target / "manifest.json"
    if manifest.exists():
        return _read_cache(target, root)
    samples = import_raw_folders(folders, root)  # raises before anything is written
    by_size: dict[int, list[LabelledAssembly]] = {}
    for sample in samples:
        by_size.setdefault(sample.size, []).append(sample)
    shards = {
        str(size): write_shard(target / f"A{size}{SHARD_SUFFIX}", group).to_json()
        for size, group in sorted(by_size.items())
    }
    write_json_atomic(manifest, {"root": str(Path(root).absolute()), "shards": shards}, indent=2)
    log.info("imported %d raw assemblies from %s into %s", len(samples), root, target)
    return [s for size in sorted(by_size) for s in by_size[size]]


def read_raw_tree(root: str | Path, cache: str | Path) -> list[LabelledAssembly]:
    """All raw assemblies under `root`: from the cache if imported before, else parsed (every
    folder checked) without writing anything."""
    folders = find_raw_folders(root)
    target = _cache_folder(folders, cache)
    if (target / "manifest.json").exists():
        return _read_cache(target, root)
    return sorted(import_raw_folders(folders, root), key=lambda s: s.size)


def select_sizes(
    samples: list[LabelledAssembly], sizes: dict[int, int] | None
) -> list[LabelledAssembly]:
    """The first `count` samples of each size in `sizes` (all samples when `sizes` is None)."""
    if sizes is None:
        return samples
    out = []
    for size, count in requested_sizes(sizes).items():
        group = [s for s in samples if s.size == size]
        if len(group) < count:
            log.warning(
                "raw data set has %d assemblies of size %d, %d requested", len(group), size, count
            )
        out.extend(group[:count])
    return out


@dataclass
class RawSource:
    """Raw assembly folders found recursively under `path`, imported once into `data_dir`."""

    data_dir: str
    path: str | None = None
    sizes: dict[int, int] | None = None

    def load(self) -> list[LabelledAssembly]:
        """The selected assemblies (see the module docstring)."""
        self._check_path()
        return select_sizes(import_raw_tree(self.path, self.data_dir), self.sizes)

    def _check_path(self) -> None:
        if not self.path:
            raise UserError(
                "dataset=raw needs dataset.path; fix: add dataset.path=/folder/of/assembly/folders"
            )

    def counts(self) -> dict[int, int]:
        """Assemblies per size that :meth:`load` returns, found without writing anything (a
        first run parses the folders twice: here, to check them, and in :meth:`load`)."""
        self._check_path()
        selected = select_sizes(read_raw_tree(self.path, self.data_dir), self.sizes)
        return dict(sorted(Counter(sample.size for sample in selected).items()))
