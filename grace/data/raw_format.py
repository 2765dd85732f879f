"""The original data set's raw folder format (SPEC §3) ↔ LabelledAssembly.

One folder per assembly:
- `assembly.spec`: `begin Pieces`, one `<name> <type> <pose>` line per part, `end Pieces`; the pose
  is the 4×4 matrix row-major, `;` within rows, `&` between rows.
- `distances.csv`: `<part>_surface_<k>,<part>_surface_<k>,<value>` rows; export writes every pair of
  surfaces of different parts that are parallel (the floored gap), and any pair whose relation
  differs from the geometry; import starts from the geometry and lets the rows override it (both
  directions).
- `solutions.csv`: one complete order per line, part names separated by `,`.
- `inter_solutions.csv`: partial orders that reach a dead end (optional on import). Export writes
  every dead end of the ground-truth DAG, for feasible assemblies too, so that the DAG imports
  back exactly (GroundTruth.from_orders spans the same states).

Numbers are written integral-without-`.0` or as the shortest `repr`, so a round trip
(export → import → export) gives byte-identical files. A malformed folder raises
:class:`RawFormatError` naming the file, the line and the fix, before anything is written.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from grace.data.atomic import write_text_atomic
from grace.domain.assembly import Assembly, Part, PartType
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError

SPEC_FILE = "assembly.spec"
DISTANCES_FILE = "distances.csv"
SOLUTIONS_FILE = "solutions.csv"
DEAD_ENDS_FILE = "inter_solutions.csv"
RAW_FILES = (SPEC_FILE, DISTANCES_FILE, SOLUTIONS_FILE, DEAD_ENDS_FILE)


class RawFormatError(UserError):
    """A raw assembly folder that does not follow the raw format (docs/raw-format.md)."""


def _error(path: Path, line: int | None, problem: str, fix: str) -> RawFormatError:
    where = f"{path}:{line}" if line is not None else str(path)
    return RawFormatError(f"{where}: {problem}; fix: {fix}")


def format_number(value: float) -> str:
    """Deterministic, lossless text for a number: `3`, `-0.5`, `1e-07` (shortest repr)."""
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"cannot write non-finite number {value!r} in the raw format")
    if value.is_integer():
        return str(int(value))
    return repr(value)


# ---------------------------------------------------------------- export


def _spec_text(assembly: Assembly) -> str:
    lines = ["begin Pieces"]
    for part in assembly.parts:
        rows = "&".join(";".join(format_number(v) for v in row) for row in part.pose)
        lines.append(f"{part.name} {part.type.value} {rows}")
    lines.append("end Pieces")
    return "\n".join(lines) + "\n"


def _distances_text(assembly: Assembly) -> str:
    rel, geo = assembly.relations, assembly.geometric_relations()
    if not np.array_equal(rel, rel.T):
        raise ValueError(
            f"assembly {assembly.name!r}: relations are not symmetric; SPEC §4 edges are undirected"
        )
    surfaces, names = assembly.surfaces(), assembly.surface_names()
    lines = []
    for i, a in enumerate(surfaces):
        for j in range(i, len(surfaces)):
            parallel = a.part != surfaces[j].part and geo[i, j] >= 0
            if parallel or rel[i, j] != geo[i, j]:
                lines.append(f"{names[i]},{names[j]},{format_number(rel[i, j])}")
    return "".join(line + "\n" for line in lines)


def _orders_text(orders: Sequence[Sequence[int]], names: Sequence[str]) -> str:
    return "".join(",".join(names[p] for p in order) + "\n" for order in orders if order)


def export_raw(sample: LabelledAssembly, folder: str | Path) -> None:
    """Write `sample` as a raw assembly folder (each file atomically, all built before writing)."""
    assembly, truth = sample.assembly, sample.truth
    names = [p.name for p in assembly.parts]
    for name in names:
        if not name or any(c.isspace() or c == "," for c in name):
            raise ValueError(
                f"part name {name!r} cannot be written: names need no spaces or commas"
            )
    texts = {
        SPEC_FILE: _spec_text(assembly),
        DISTANCES_FILE: _distances_text(assembly),
        SOLUTIONS_FILE: _orders_text(list(truth.orders()), names),
        DEAD_ENDS_FILE: _orders_text(list(truth.dead_ends()), names),
    }
    folder = Path(folder)
    for file, text in texts.items():
        write_text_atomic(folder / file, text)


# ---------------------------------------------------------------- import


def _read_lines(path: Path) -> list[str]:
    if not path.is_file():
        raise _error(
            path, None, "missing file", f"every assembly folder needs {', '.join(RAW_FILES[:3])}"
        )
    try:
        return path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError as e:
        raise _error(
            path, None, f"not UTF-8 text ({e.reason})", "save the file as UTF-8 text"
        ) from e


def _parse_number(text: str, path: Path, line: int, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise _error(
            path, line, f"{what} {text!r} is not a finite number", f"write {what} as a number"
        )
    return value


def _parse_pose(text: str, path: Path, line: int) -> np.ndarray:
    rows = text.split("&")
    cells = [row.split(";") for row in rows]
    if len(rows) != 4 or any(len(row) != 4 for row in cells):
        raise _error(
            path,
            line,
            f"pose {text!r} is not a 4×4 matrix",
            "write 16 numbers row-major, ';' between entries and '&' between the 4 rows",
        )
    return np.array([[_parse_number(c, path, line, "pose entry") for c in row] for row in cells])


def _parse_spec(path: Path) -> list[Part]:
    lines = _read_lines(path)
    content = [(i + 1, line.strip()) for i, line in enumerate(lines) if line.strip()]
    if not content or content[0][1] != "begin Pieces":
        first = content[0][0] if content else 1
        raise _error(
            path, first, "first line is not 'begin Pieces'", "start the file with 'begin Pieces'"
        )
    if content[-1][1] != "end Pieces" or len(content) < 2:
        raise _error(
            path, content[-1][0], "last line is not 'end Pieces'", "end the file with 'end Pieces'"
        )
    parts: list[Part] = []
    seen: set[str] = set()
    known = ", ".join(t.value for t in PartType)
    for number, line in content[1:-1]:
        fields = line.split()
        if len(fields) != 3:
            raise _error(
                path,
                number,
                f"expected '<name> <type> <pose>', got {line!r}",
                "write three fields separated by spaces",
            )
        name, kind, pose = fields
        try:
            part_type = PartType(kind)
        except ValueError:
            raise _error(
                path, number, f"unknown part type {kind!r}", f"use one of {known}"
            ) from None
        if name in seen:
            raise _error(
                path, number, f"duplicate part name {name!r}", "give every part a unique name"
            )
        seen.add(name)
        parts.append(Part(name, part_type, _parse_pose(pose, path, number)))
    if not parts:
        raise _error(
            path,
            content[-1][0],
            "no parts between 'begin Pieces' and 'end Pieces'",
            "list one line per part",
        )
    return parts


def _parse_distances(path: Path, assembly: Assembly) -> np.ndarray:
    index = {name: i for i, name in enumerate(assembly.surface_names())}
    relations = assembly.relations.copy()
    for number, line in enumerate(_read_lines(path), start=1):
        if not line.strip():
            continue
        fields = [f.strip() for f in line.split(",")]
        if len(fields) != 3:
            raise _error(
                path,
                number,
                f"expected '<surface>,<surface>,<value>', got {line!r}",
                "write three comma-separated fields",
            )
        for surface in fields[:2]:
            if surface not in index:
                raise _error(
                    path,
                    number,
                    f"surface {surface!r} is not a surface of a part in {SPEC_FILE}",
                    "name surfaces '<part>_surface_<k>' after a listed part, k within its surfaces",
                )
        value = _parse_number(fields[2], path, number, "relation value")
        i, j = index[fields[0]], index[fields[1]]
        relations[i, j] = relations[j, i] = value
    return relations


def _parse_orders(path: Path, names: Sequence[str], complete: bool) -> list[tuple[int, ...]]:
    index = {name: i for i, name in enumerate(names)}
    orders = []
    for number, line in enumerate(_read_lines(path), start=1):
        if not line.strip():
            continue
        order = []
        for name in (f.strip() for f in line.split(",")):
            if name not in index:
                raise _error(
                    path,
                    number,
                    f"part {name!r} is not in {SPEC_FILE}",
                    "use the part names of assembly.spec",
                )
            order.append(index[name])
        if len(set(order)) != len(order):
            raise _error(
                path,
                number,
                "a part appears twice in one order",
                "list each part at most once per line",
            )
        if complete and len(order) != len(names):
            raise _error(
                path,
                number,
                f"order has {len(order)} of {len(names)} parts",
                f"list complete orders here and partial ones in {DEAD_ENDS_FILE}",
            )
        orders.append(tuple(order))
    return orders


def import_raw(folder: str | Path) -> LabelledAssembly:
    """Read one raw assembly folder; relations from the poses overridden by `distances.csv`."""
    folder = Path(folder)
    parts = _parse_spec(folder / SPEC_FILE)
    assembly = Assembly(tuple(parts), name=folder.name)
    assembly.relations = _parse_distances(folder / DISTANCES_FILE, assembly)
    names = [p.name for p in parts]
    orders = _parse_orders(folder / SOLUTIONS_FILE, names, complete=True)
    dead_path = folder / DEAD_ENDS_FILE
    dead_ends = _parse_orders(dead_path, names, complete=False) if dead_path.exists() else []
    truth = GroundTruth.from_orders(len(parts), orders, dead_ends)
    return LabelledAssembly(assembly, truth, {})


def find_raw_folders(root: str | Path) -> list[Path]:
    """Assembly folders under `root` (any depth, sorted): folders holding one of the raw files."""
    root = Path(root)
    if not root.is_dir():
        raise _error(
            root, None, "not a folder", "set dataset.path to a folder of raw assembly folders"
        )
    folders = sorted(
        {p.parent for name in RAW_FILES for p in root.rglob(name)},
        key=lambda p: p.relative_to(root).parts,
    )
    if not folders:
        raise _error(
            root,
            None,
            f"no assembly folders (none holds {SPEC_FILE})",
            "set dataset.path to a folder of raw assembly folders",
        )
    return folders
