"""The original data set's raw folder format (docs/raw-format.md) ↔ LabelledAssembly.

One folder per assembly:
- `assembly.spec`: `begin Pieces`, one `<name> <type> <pose>` line per part, `end Pieces`; the pose
  is the 4×4 matrix row-major, `;` within rows, `&` between rows, in mm. Parts lie on the table
  and are axis-aligned (docs/assembly-graph.md): the rotation is a quarter turn about z, z = 0.
- `distances.csv`: `<part>_surface_<k>,<part>_surface_<k>,<value>` rows; export writes every pair of
  surfaces of different parts that are parallel (the floored gap), and any pair whose relation
  differs from the geometry; import starts from the geometry and lets the rows override it (both
  directions). A value is a distance ≥ 0 (mm) or −1 (orthogonal).
- `solutions.csv`: one complete order per line, part names separated by `,`.
- `inter_solutions.csv`: partial orders that reach a dead end (optional on import). Export writes,
  for feasible assemblies too, dead ends that together take every placement step of the
  ground-truth DAG that no complete order takes (GroundTruth.dead_ends: at most one line per
  such step, not every dead-end path, whose number grows factorially), so that the DAG imports
  back exactly (GroundTruth.from_orders spans the same states and steps). A dead end contradicts
  the other lines when the state it ends in (the set of its parts) is left by another line: see
  :func:`_check_dead_ends`.

Every file may start with a UTF-8 byte-order mark and use `\\r\\n` line ends; blank lines are
skipped. Numbers are written integral-without-`.0` or as the shortest `repr`, so a round trip
(export → import → export) gives byte-identical files. A malformed folder raises
:class:`RawFormatError` naming the file, the line and the fix, before anything is written;
:func:`import_raw_folders` checks every folder of a tree and reports all bad ones at once.
"""

from __future__ import annotations

import codecs
import math
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np

from grace.data.atomic import write_lines_atomic, write_text_atomic
from grace.domain.assembly import Assembly, Part, PartType
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.errors import UserError

ASSEMBLY_FILE = "assembly.spec"
DISTANCES_FILE = "distances.csv"
SOLUTIONS_FILE = "solutions.csv"
DEAD_ENDS_FILE = "inter_solutions.csv"
RAW_FILES = (ASSEMBLY_FILE, DISTANCES_FILE, SOLUTIONS_FILE, DEAD_ENDS_FILE)

POSE_TOLERANCE = 1e-6
"""Largest deviation (rotation entries, and mm for z) from an exact table pose that import accepts:
tools that write `cos 90°` as 6e-17 stay importable, a 45° turn or a 1 µm lift do not."""

WORKSPACE_MM = 2000.0
"""Largest |x| and |y| of a part's position (mm, world frame of docs/world.md: origin at the
work-area centre): the cell's arms stand at x = ±520 mm and reach 820 mm, plus flange and gripper
about 1.6 m from the centre, so nothing beyond 2 m can be handled in the cell."""

MAX_DISTANCE_MM = 2 * math.sqrt(2) * WORKSPACE_MM
"""Largest distance between two parallel surfaces in `distances.csv`: the diagonal of the
workspace square (5657 mm)."""

MAX_PARTS = 63
"""Ground-truth states are 64-bit part masks (grace.domain.orders), so 63 parts at most."""

MAX_REPORTED_FOLDERS = 20
"""Bad folders listed one per line in a tree's error; the rest are counted."""


class RawFormatError(UserError):
    """A raw assembly folder that does not follow the raw format (docs/raw-format.md)."""


class RawTreeError(RawFormatError):
    """Malformed folders of one tree, all reported at once; `errors` holds each folder's error."""

    def __init__(self, message: str, errors: Sequence[RawFormatError]) -> None:
        super().__init__(message)
        self.errors = list(errors)


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


def _is_relation_value(value: float) -> bool:
    """A distance between parallel planes (0 to :data:`MAX_DISTANCE_MM`) or the orthogonal code
    −1."""
    return math.isfinite(value) and (0 <= value <= MAX_DISTANCE_MM or value == -1)


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
            f"assembly {assembly.name!r}: relations are not symmetric; surface-surface edges are "
            "undirected (docs/assembly-graph.md)"
        )
    surfaces, names = assembly.surfaces(), assembly.surface_names()
    lines = []
    for i, a in enumerate(surfaces):
        for j in range(i, len(surfaces)):
            parallel = a.part != surfaces[j].part and geo[i, j] >= 0
            if parallel or rel[i, j] != geo[i, j]:
                if not _is_relation_value(rel[i, j]):
                    raise ValueError(
                        f"assembly {assembly.name!r}: relation {rel[i, j]} between {names[i]} and "
                        f"{names[j]} is neither a distance ≥ 0 nor −1, so it cannot be imported"
                    )
                lines.append(f"{names[i]},{names[j]},{format_number(rel[i, j])}")
    return "".join(line + "\n" for line in lines)


def _order_lines(orders: Iterable[Sequence[int]], names: Sequence[str]) -> Iterator[str]:
    return (",".join(names[p] for p in order) + "\n" for order in orders if order)


def export_raw(sample: LabelledAssembly, folder: str | Path) -> None:
    """Write `sample` as a raw assembly folder, each file atomically; the order files line by
    line as the ground truth lists them (memory stays flat, however many orders)."""
    assembly, truth = sample.assembly, sample.truth
    names = [p.name for p in assembly.parts]
    for name in names:
        if not name or any(c.isspace() or c == "," for c in name):
            raise ValueError(
                f"part name {name!r} cannot be written: names need no spaces or commas"
            )
    texts = {
        ASSEMBLY_FILE: _spec_text(assembly),
        DISTANCES_FILE: _distances_text(assembly),
    }
    folder = Path(folder)
    for file, text in texts.items():
        write_text_atomic(folder / file, text)
    write_lines_atomic(folder / SOLUTIONS_FILE, _order_lines(truth.orders(), names))
    write_lines_atomic(folder / DEAD_ENDS_FILE, _order_lines(truth.dead_ends(), names))


# ---------------------------------------------------------------- import


def _read_lines(path: Path) -> list[str]:
    """The file's lines; a UTF-8 byte-order mark (as Windows tools write) is dropped."""
    if not path.is_file():
        raise _error(
            path, None, "missing file", f"every assembly folder needs {', '.join(RAW_FILES[:3])}"
        )
    try:
        data = path.read_bytes().removeprefix(codecs.BOM_UTF8)
    except OSError as e:
        raise _error(
            path, None, f"cannot be read ({e.strerror})", "make it a readable file"
        ) from None
    try:
        return data.decode("utf-8").splitlines()
    except UnicodeDecodeError as e:
        line = data[: e.start].count(b"\n") + 1
        raise _error(
            path, line, f"byte {data[e.start]:#04x} is not UTF-8 text", "save the file as UTF-8"
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


def _close(a: np.ndarray | float, b: object) -> bool:
    return bool(np.all(np.abs(np.asarray(a) - np.asarray(b)) <= POSE_TOLERANCE))


def _check_pose(pose: np.ndarray, path: Path, line: int) -> None:
    """Reject what the domain cannot represent: only quarter turns about z, on the table."""
    rotation = pose[:3, :3]
    if not _close(pose[3], [0, 0, 0, 1]):
        row = ";".join(format_number(v) for v in pose[3])
        raise _error(
            path,
            line,
            f"pose's last row is {row}, not 0;0;0;1",
            "end the pose with the row 0;0;0;1 (a rigid transform)",
        )
    if not _close(rotation @ rotation.T, np.eye(3)):
        lengths = ", ".join(f"{v:.6g}" for v in np.linalg.norm(rotation, axis=1))
        raise _error(
            path,
            line,
            f"pose is scaled or sheared: the rows of its 3×3 rotation block have lengths {lengths} "
            "and are not orthonormal",
            "write a pure rotation (the part's size comes from its type, not from the pose)",
        )
    if np.linalg.det(rotation) < 0:
        raise _error(
            path,
            line,
            "pose mirrors the part (its rotation block has determinant -1)",
            "write a rotation about z by a multiple of 90° (determinant +1)",
        )
    if not _close(rotation[2], [0, 0, 1]):
        axis = ", ".join(f"{v:.6g}" for v in rotation[:, 2])
        raise _error(
            path,
            line,
            f"pose tilts the part off the table (its z axis points along ({axis}))",
            "rotate parts about z only: they lie flat on the table",
        )
    degrees = math.degrees(math.atan2(rotation[1, 0], rotation[0, 0]))
    quarter = round(degrees / 90.0)
    c, s = round(math.cos(quarter * math.pi / 2)), round(math.sin(quarter * math.pi / 2))
    if not _close(rotation[:2, :2], [[c, -s], [s, c]]):
        raise _error(
            path,
            line,
            f"pose turns the part by {degrees:.6g}° about z, not a multiple of 90°",
            "rotate parts by 0, 90, 180 or 270° about z: parts are axis-aligned",
        )
    for axis, value in (("x", pose[0, 3]), ("y", pose[1, 3])):
        if abs(value) > WORKSPACE_MM:
            raise _error(
                path,
                line,
                f"pose puts the part at {axis} = {value:.6g} mm, outside the cell's "
                f"workspace (|x|, |y| ≤ {format_number(WORKSPACE_MM)} mm)",
                "write positions in millimetres in the world frame of docs/world.md (origin at "
                "the work-area centre)",
            )
    if not _close(pose[2, 3], 0.0):
        raise _error(
            path,
            line,
            f"pose puts the part at z = {format_number(pose[2, 3])} mm, off the table",
            "set the z translation (4th entry of the 3rd row) to 0: parts lie on the table",
        )


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
    pose = np.array([[_parse_number(c, path, line, "pose entry") for c in row] for row in cells])
    with np.errstate(over="ignore", invalid="ignore"):  # a huge entry is refused below anyway
        _check_pose(pose, path, line)
    return pose


def _parse_spec(path: Path) -> list[Part]:
    lines = _read_lines(path)
    content = [(i + 1, line.strip()) for i, line in enumerate(lines) if line.strip()]
    if not content:
        raise _error(
            path, None, "file is empty", "write 'begin Pieces', one line per part, 'end Pieces'"
        )
    if content[0][1] != "begin Pieces":
        raise _error(
            path,
            content[0][0],
            f"first line is {content[0][1]!r}, not 'begin Pieces'",
            "start the file with 'begin Pieces'",
        )
    if content[-1][1] != "end Pieces" or len(content) < 2:
        raise _error(
            path, content[-1][0], "last line is not 'end Pieces'", "end the file with 'end Pieces'"
        )
    parts: list[Part] = []
    seen: dict[str, int] = {}
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
        if "," in name:
            raise _error(
                path,
                number,
                f"part name {name!r} contains ','",
                "rename the part: the order files separate part names by ','",
            )
        try:
            part_type = PartType(kind)
        except ValueError:
            raise _error(
                path, number, f"unknown part type {kind!r}", f"use one of {known}"
            ) from None
        if name in seen:
            raise _error(
                path,
                number,
                f"duplicate part name {name!r} (also on line {seen[name]})",
                "give every part a unique name",
            )
        seen[name] = number
        parts.append(Part(name, part_type, _parse_pose(pose, path, number)))
    if not parts:
        raise _error(
            path,
            content[-1][0],
            "no parts between 'begin Pieces' and 'end Pieces'",
            "list one line per part",
        )
    if len(parts) > MAX_PARTS:
        raise _error(
            path,
            content[-1][0],
            f"{len(parts)} parts, more than the {MAX_PARTS} an assembly state can hold",
            f"split the assembly into assemblies of at most {MAX_PARTS} parts",
        )
    return parts


def _parse_distances(path: Path, assembly: Assembly) -> np.ndarray:
    index = {name: i for i, name in enumerate(assembly.surface_names())}
    relations = assembly.relations.copy()
    given: dict[tuple[int, int], tuple[float, int]] = {}
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
                    f"surface {surface!r} is not a surface of a part in {ASSEMBLY_FILE}",
                    "name surfaces '<part>_surface_<k>' after a listed part, k within its surfaces",
                )
        value = _parse_number(fields[2], path, number, "relation value")
        if not _is_relation_value(value):
            problem = "is negative" if value < 0 else "is beyond the cell's workspace"
            raise _error(
                path,
                number,
                f"relation value {fields[2]} {problem}",
                f"write a distance from 0 to {MAX_DISTANCE_MM:.0f} mm, or -1 for orthogonal "
                "surfaces",
            )
        i, j = index[fields[0]], index[fields[1]]
        pair = (min(i, j), max(i, j))
        if pair in given and given[pair][0] != value:
            raise _error(
                path,
                number,
                f"{fields[0]},{fields[1]} is {fields[2]} here but "
                f"{format_number(given[pair][0])} on line {given[pair][1]}",
                "keep one row per pair of surfaces",
            )
        given[pair] = (value, number)
        relations[i, j] = relations[j, i] = value
    return relations


def _parse_orders(
    path: Path, names: Sequence[str], complete: bool
) -> list[tuple[int, tuple[int, ...]]]:
    """(line number, order) per non-blank line; `complete` orders list every part."""
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
                    f"part {name!r} is not in {ASSEMBLY_FILE}",
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
        if not complete and len(order) == len(names):
            raise _error(
                path,
                number,
                f"dead end lists all {len(names)} parts, a complete order",
                f"move complete orders to {SOLUTIONS_FILE}",
            )
        orders.append((number, tuple(order)))
    return orders


def _check_dead_ends(
    folder: Path,
    orders: Sequence[tuple[int, tuple[int, ...]]],
    dead_ends: Sequence[tuple[int, tuple[int, ...]]],
    names: Sequence[str],
) -> None:
    """A dead-end line must end in a state that no listed line leaves.

    The ground truth is a DAG over states, a state being the set of placed parts
    (grace.domain.orders): a dead end claims that no part can be placed once its parts are. A
    line of either file that places the same parts first (in any order) and then places another
    one contradicts that claim; so does a dead end that is a prefix of a solution. Such a line
    would otherwise vanish silently into the DAG.
    """
    leaves: dict[int, tuple[str, int, tuple[int, ...]]] = {}
    for file, lines in ((SOLUTIONS_FILE, orders), (DEAD_ENDS_FILE, dead_ends)):
        for number, order in lines:
            state = 0
            for part in order[:-1]:
                state |= 1 << part
                leaves.setdefault(state, (file, number, order))
    for number, order in dead_ends:
        state = sum(1 << part for part in order)
        if state in leaves:
            file, other, continued = leaves[state]
            raise _error(
                folder / DEAD_ENDS_FILE,
                number,
                f"dead end {','.join(names[p] for p in order)} is continued by {file} line "
                f"{other} ({','.join(names[p] for p in continued)}), which places the same parts "
                "first and then another one",
                "a dead end must end where no listed order goes on: delete one of the two lines",
            )


def import_raw(folder: str | Path) -> LabelledAssembly:
    """Read one raw assembly folder; relations from the poses overridden by `distances.csv`."""
    folder = Path(folder)
    parts = _parse_spec(folder / ASSEMBLY_FILE)
    assembly = Assembly(tuple(parts), name=folder.name)
    assembly.relations = _parse_distances(folder / DISTANCES_FILE, assembly)
    names = [p.name for p in parts]
    orders = _parse_orders(folder / SOLUTIONS_FILE, names, complete=True)
    dead_path = folder / DEAD_ENDS_FILE
    dead_ends = _parse_orders(dead_path, names, complete=False) if dead_path.exists() else []
    _check_dead_ends(folder, orders, dead_ends, names)
    truth = GroundTruth.from_orders(len(parts), [o for _, o in orders], [o for _, o in dead_ends])
    return LabelledAssembly(assembly, truth, {})


def read_assembly(path: str | Path) -> tuple[Assembly, GroundTruth | None]:
    """An assembly to plan: a raw folder (with `solutions.csv` also its ground truth, with
    `distances.csv` its relations) or a lone `assembly.spec` (relations from the poses)."""
    path = Path(path)
    spec = path / ASSEMBLY_FILE if path.is_dir() else path
    if not spec.is_file():
        raise _error(
            spec, None, "no such file", f"pass a raw assembly folder or its {ASSEMBLY_FILE} file"
        )
    folder = spec.parent
    if (folder / SOLUTIONS_FILE).is_file() and (folder / DISTANCES_FILE).is_file():
        sample = import_raw(folder)
        return sample.assembly, sample.truth
    assembly = Assembly(tuple(_parse_spec(spec)), name=folder.name)
    if (folder / DISTANCES_FILE).is_file():
        assembly.relations = _parse_distances(folder / DISTANCES_FILE, assembly)
    return assembly, None


def import_raw_folders(
    folders: Sequence[Path], root: str | Path, limit: int = MAX_REPORTED_FOLDERS
) -> list[LabelledAssembly]:
    """Import every folder, or raise one RawTreeError that lists every bad one.

    The message's first line is a summary with the first folder's problem, so a single bad
    folder gives a single line; each further bad folder adds one line (file, line, fix), up to
    `limit` folders, then a count of the rest. The errors themselves are in `.errors`.
    """
    samples, errors = [], []
    for folder in folders:
        try:
            samples.append(import_raw(folder))
        except RawFormatError as e:
            errors.append(e)
    if not errors:
        return samples
    verb = "is" if len(errors) == 1 else "are"
    lines = [f"{len(errors)} of {len(folders)} raw folders under {root} {verb} malformed:"]
    lines[0] += f" {errors[0]}"
    lines += [str(e) for e in errors[1:limit]]
    if len(errors) > limit:
        lines.append(f"and {len(errors) - limit} more malformed folders")
    raise RawTreeError("\n".join(lines), errors)


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
            f"no assembly folders (none holds {ASSEMBLY_FILE})",
            "set dataset.path to a folder of raw assembly folders",
        )
    return folders
