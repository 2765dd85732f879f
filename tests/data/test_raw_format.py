import codecs
import math
from pathlib import Path

import numpy as np
import pytest
from hydra.utils import instantiate

from grace.data.loading import RawSource, import_raw_tree
from grace.data.raw_format import (
    RAW_FILES,
    RawFormatError,
    RawTreeError,
    export_raw,
    find_raw_folders,
    format_number,
    import_raw,
    import_raw_folders,
)
from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly


def _files(folder: Path) -> dict[str, bytes]:
    return {name: (folder / name).read_bytes() for name in RAW_FILES}


def _bracket_frame() -> LabelledAssembly:
    """A T-joint with a bracket in its corner, a fractional pose and an imported-style relation."""
    bar = Part("bar", PartType.PROFILE_300, planar_pose(0, 0, 1))
    stem = Part("stem", PartType.PROFILE_200, planar_pose(0.25, 120))
    bracket = Part("br", PartType.BRACKET, planar_pose(20.25, 20))
    assembly = Assembly((bar, stem, bracket), name="frame")
    relations = assembly.relations.copy()
    relations[0, 5] = relations[5, 0] = 12.5  # an override as distances.csv may carry
    assembly.relations = relations
    truth = GroundTruth.explore(3, lambda state, part: part != 2 or state == 0b011)
    return LabelledAssembly(assembly, truth, {})


def test_format_number_is_shortest_and_lossless():
    assert [format_number(v) for v in (3.0, -0.0, 0.1, 1e-7, 120)] == [
        "3",
        "0",
        "0.1",
        "1e-07",
        "120",
    ]
    for v in (0.1, 1 / 3, 6.123233995736766e-17, -250.75):
        assert float(format_number(v)) == v


# The frame's distances.csv derived by hand from its poses (module docstring of
# grace.domain.assembly): x-facing surfaces lie at x = bar_1 −150, bar_3 150, stem_2 20.25,
# stem_4 −19.75, br_1 20.25; y-facing ones at y = bar_2 20, bar_4 −20, stem_1 220, stem_3 20,
# br_2 20. Each row is the floored gap, except the 12.5 override.
FRAME_DISTANCES = """\
bar_surface_1,stem_surface_2,12.5
bar_surface_1,stem_surface_4,130
bar_surface_1,br_surface_1,170
bar_surface_2,stem_surface_1,200
bar_surface_2,stem_surface_3,0
bar_surface_2,br_surface_2,0
bar_surface_3,stem_surface_2,129
bar_surface_3,stem_surface_4,169
bar_surface_3,br_surface_1,129
bar_surface_4,stem_surface_1,240
bar_surface_4,stem_surface_3,40
bar_surface_4,br_surface_2,40
stem_surface_1,br_surface_2,200
stem_surface_2,br_surface_1,0
stem_surface_3,br_surface_2,0
stem_surface_4,br_surface_1,40
"""

FRAME_PIECES = """\
begin Pieces
bar item_profile_300 0;-1;0;0&1;0;0;0&0;0;1;0&0;0;0;1
stem item_profile_200 1;0;0;0.25&0;1;0;120&0;0;1;0&0;0;0;1
br item_angle_bracket 1;0;0;20.25&0;1;0;20&0;0;1;0&0;0;0;1
end Pieces
"""


def test_export_layout(tmp_path):
    export_raw(_bracket_frame(), tmp_path / "frame")
    assert (tmp_path / "frame" / "assembly.spec").read_text() == FRAME_PIECES
    assert (tmp_path / "frame" / "distances.csv").read_text() == FRAME_DISTANCES
    assert (tmp_path / "frame" / "solutions.csv").read_text() == "bar,stem,br\nstem,bar,br\n"
    assert (tmp_path / "frame" / "inter_solutions.csv").read_text() == ""


@pytest.mark.parametrize("seed", range(6))
def test_round_trip_is_exact(tmp_path, fake_simulator, seed):
    samples = [_bracket_frame(), instantiate(fake_simulator).sample(5, np.random.default_rng(seed))]
    for k, sample in enumerate(samples):
        sample.info = {}
        first, second = tmp_path / f"a{k}", tmp_path / f"b{k}"
        export_raw(sample, first)
        imported = import_raw(first)
        assert imported == sample
        assert imported.truth.naive_checks == sample.truth.naive_checks
        export_raw(imported, second)
        assert _files(first) == _files(second)
        assert import_raw(second) == imported


def test_infeasible_assembly_keeps_its_dead_ends(tmp_path):
    truth = GroundTruth.explore(
        3, lambda state, part: part == 0 or (part == 1 and not state & 4) or state == 0b001
    )
    assert not truth.feasible
    sample = _bracket_frame()
    sample.truth = truth
    export_raw(sample, tmp_path / "x")
    assert (tmp_path / "x" / "solutions.csv").read_text() == ""
    assert (tmp_path / "x" / "inter_solutions.csv").read_text().splitlines() == [
        "bar,stem",
        "bar,br",
        "stem,bar",
    ]
    assert import_raw(tmp_path / "x").truth == truth


def test_dead_ends_are_bounded_by_the_dag_and_read_back_by_dataset_raw(tmp_path):
    """One order completes (0, 1, …, 8); placed before part 0, the others go in any order and
    end stuck: 8! = 40320 dead-end paths. inter_solutions.csv holds at most one line per step
    off the complete orders (8·2^7 = 1024), and dataset=raw reads the exact ground truth."""
    n = 9

    def can_place(state: int, part: int) -> bool:
        if part == 0:
            return state == 0
        return state == (1 << part) - 1 if state & 1 else True

    truth = GroundTruth.explore(n, can_place)
    masks = zip(truth.states.tolist(), truth.placeable.tolist(), strict=True)
    stuck = {s for s, p in masks if not p}
    paths = truth.path_counts()
    assert sum(paths[s] for s in stuck if s != (1 << n) - 1) == math.factorial(n - 1)
    steps = zip(truth.placeable.tolist(), truth.completable.tolist(), strict=True)
    off_steps = sum((p & ~c).bit_count() for p, c in steps)
    assert off_steps == (n - 1) * 2 ** (n - 2)
    parts = tuple(
        Part(f"p{k}", PartType.PROFILE_200, planar_pose(300 * (k % 3), 300 * (k // 3)))
        for k in range(n)
    )
    sample = LabelledAssembly(Assembly(parts, name="stuck"), truth, {})
    export_raw(sample, tmp_path / "raw" / "A9" / "stuck")
    lines = (tmp_path / "raw" / "A9" / "stuck" / "inter_solutions.csv").read_text().splitlines()
    assert 0 < len(lines) <= off_steps and lines == sorted(lines, key=lambda x: x.split(","))
    (imported,) = RawSource(data_dir=str(tmp_path / "data"), path=str(tmp_path / "raw")).load()
    assert imported.truth == truth and imported.truth.n_orders() == 1


def test_missing_inter_solutions_is_optional(tmp_path):
    export_raw(_bracket_frame(), tmp_path / "x")
    (tmp_path / "x" / "inter_solutions.csv").unlink()
    assert import_raw(tmp_path / "x").truth.n_orders() == 2


def test_find_raw_folders_any_depth(tmp_path):
    export_raw(_bracket_frame(), tmp_path / "A3" / "b")
    export_raw(_bracket_frame(), tmp_path / "A3" / "a")
    (tmp_path / "notes").mkdir()
    assert find_raw_folders(tmp_path) == [tmp_path / "A3" / "a", tmp_path / "A3" / "b"]
    with pytest.raises(RawFormatError, match="no assembly folders"):
        find_raw_folders(tmp_path / "notes")


def test_any_symmetric_relation_override_survives(tmp_path):
    sample = _bracket_frame()
    relations = sample.assembly.relations.copy()
    relations[0, 1] = relations[1, 0] = 2.5  # same part
    relations[3, 3] = 9.0  # self loop
    relations[2, 6] = relations[6, 2] = 0.125  # orthogonal pair
    sample.assembly.relations = relations
    export_raw(sample, tmp_path / "a")
    assert import_raw(tmp_path / "a") == sample
    export_raw(import_raw(tmp_path / "a"), tmp_path / "b")
    assert _files(tmp_path / "a") == _files(tmp_path / "b")
    sample.assembly.relations[0, 1] = 4.0
    with pytest.raises(ValueError, match="not symmetric"):
        export_raw(sample, tmp_path / "c")
    assert not (tmp_path / "c").exists()


def test_byte_order_mark_and_crlf_are_read_transparently(tmp_path):
    sample = _bracket_frame()
    export_raw(sample, tmp_path / "frame")
    for name in RAW_FILES:
        path = tmp_path / "frame" / name
        text = path.read_text().replace("\n", "\r\n")
        path.write_bytes(codecs.BOM_UTF8 + text.encode("utf-8"))
    assert import_raw(tmp_path / "frame") == sample


def test_byte_order_mark_keeps_line_numbers(tmp_path):
    export_raw(_bracket_frame(), tmp_path / "frame")
    spec = tmp_path / "frame" / "assembly.spec"
    spec.write_bytes(codecs.BOM_UTF8 + FRAME_PIECES.replace("0.25", "\xff").encode("latin-1"))
    with pytest.raises(RawFormatError, match=r"assembly\.spec:3: byte 0xff is not UTF-8"):
        import_raw(tmp_path / "frame")


def test_every_quarter_turn_and_float_noise_are_accepted(tmp_path):
    """Axis-aligned poses in all four turns, and `cos 90°` written as 6e-17, import as given."""
    eps = 6.123233995736766e-17
    noisy = np.array([[eps, -1, 0, 10.5], [1, eps, 0, -3], [0, 0, 1, 1e-9], [0, 0, 0, 1]])
    parts = [Part(f"p{k}", PartType.PROFILE_200, planar_pose(300 * k, 0, k)) for k in range(4)]
    parts.append(Part("noisy", PartType.PROFILE_300, noisy))
    sample = LabelledAssembly(
        Assembly(tuple(parts), name="turns"), GroundTruth.explore(5, lambda s, p: True), {}
    )
    export_raw(sample, tmp_path / "turns")
    imported = import_raw(tmp_path / "turns")
    assert imported == sample
    assert [p.quarter_turns for p in imported.assembly.parts] == [0, 1, 2, 3, 1]


def test_consistent_dead_ends_are_kept(tmp_path):
    """A dead end that branches off a solution, and one continued by nothing: both stay."""
    export_raw(_bracket_frame(), tmp_path / "frame")
    (tmp_path / "frame" / "inter_solutions.csv").write_text("bar,br\nbr\nbr\n")
    truth = import_raw(tmp_path / "frame").truth
    assert list(truth.dead_ends()) == [(0, 2), (2,)]
    assert list(truth.orders()) == [(0, 1, 2), (1, 0, 2)]
    assert [truth.label(s) for s in (0b000, 0b001, 0b100, 0b101)] == [0b011, 0b010, 0, 0]


# ---------------------------------------------------------------- bad input, one row per case

PIECES, DIST, SOLS, DEAD = RAW_FILES
BAR = "bar item_profile_300 {}"
FLAT = "1;0;0;0&0;1;0;0&0;0;1;0&0;0;0;1"
R45 = "0.7071067811865476;-0.7071067811865476;0;0&0.7071067811865476;0.7071067811865476;0;0"
DELETE = object()
TOO_MANY = "begin Pieces\n" + "".join(
    f"p{k} item_profile_200 1;0;0;{60 * (k % 8)}&0;1;0;{250 * (k // 8)}&0;0;1;0&0;0;0;1\n"
    for k in range(64)
)

# (file, edit, line the message names (None: the file as a whole), problem, fix). An edit is
# DELETE, the whole new content (bytes), or (line, text) replacing that line of the frame's file.
BAD_INPUT = {
    "missing spec": (PIECES, DELETE, None, "missing file", "every assembly folder needs"),
    "missing distances": (DIST, DELETE, None, "missing file", "every assembly folder needs"),
    "missing solutions": (SOLS, DELETE, None, "missing file", "every assembly folder needs"),
    "not utf-8": (PIECES, FRAME_PIECES.replace("0.25", "\xe9").encode("latin-1"), 3,
                  "byte 0xe9 is not UTF-8", "save the file as UTF-8"),
    "empty spec": (PIECES, b"", None, "file is empty", "write 'begin Pieces'"),
    "blank spec": (PIECES, b"\n  \n", None, "file is empty", "write 'begin Pieces'"),
    "no begin": (PIECES, (1, "begin Parts"), 1, "'begin Parts', not 'begin Pieces'",
                 "start the file with 'begin Pieces'"),
    "no end": (PIECES, (5, ""), 4, "last line is not 'end Pieces'", "end the file with"),
    "no parts": (PIECES, b"begin Pieces\nend Pieces\n", 2, "no parts between",
                 "list one line per part"),
    "part fields": (PIECES, (2, "bar item_profile_300"), 2, "expected '<name> <type> <pose>'",
                    "three fields"),
    "part type": (PIECES, (3, "stem item_profile_400 " + FLAT), 3,
                  "unknown part type 'item_profile_400'", "use one of item_profile_200"),
    "duplicate name": (PIECES, (3, "bar item_profile_200 " + FLAT), 3,
                       "duplicate part name 'bar' (also on line 2)", "unique name"),
    "comma in name": (PIECES, (2, "b,ar item_profile_300 " + FLAT), 2, "'b,ar' contains ','",
                      "rename the part"),
    "too many parts": (PIECES, (TOO_MANY + "end Pieces\n").encode(), 66,
                       "64 parts, more than the 63", "at most 63 parts"),
    "pose 15 entries": (PIECES, (2, BAR.format("1;0;0&0;1;0;0&0;0;1;0&0;0;0;1")), 2,
                        "is not a 4×4 matrix", "write 16 numbers"),
    "pose word": (PIECES, (2, BAR.format("1;0;0;x&0;1;0;0&0;0;1;0&0;0;0;1")), 2,
                  "pose entry 'x' is not a finite number", "write pose entry as a number"),
    "pose nan": (PIECES, (2, BAR.format("1;0;0;nan&0;1;0;0&0;0;1;0&0;0;0;1")), 2,
                 "pose entry 'nan' is not a finite number", "as a number"),
    "pose 45°": (PIECES, (2, BAR.format(R45 + "&0;0;1;0&0;0;0;1")), 2,
                 "turns the part by 45° about z", "0, 90, 180 or 270°"),
    "pose scaled ×2": (PIECES, (2, BAR.format("2;0;0;0&0;2;0;0&0;0;2;0&0;0;0;1")), 2,
                       "scaled or sheared: the rows of its 3×3 rotation block have lengths 2, 2, 2",
                       "write a pure rotation"),
    "pose sheared": (PIECES, (2, BAR.format("1;0.5;0;0&0;1;0;0&0;0;1;0&0;0;0;1")), 2,
                     "scaled or sheared", "write a pure rotation"),
    "pose mirrored": (PIECES, (2, BAR.format("1;0;0;0&0;-1;0;0&0;0;1;0&0;0;0;1")), 2,
                      "mirrors the part", "determinant +1"),
    "pose tilted": (PIECES, (2, BAR.format("1;0;0;0&0;0;-1;0&0;1;0;0&0;0;0;1")), 2,
                    "tilts the part off the table (its z axis points along (0, -1, 0))",
                    "rotate parts about z only"),
    "pose z=500": (PIECES, (2, BAR.format("1;0;0;0&0;1;0;0&0;0;1;500&0;0;0;1")), 2,
                   "at z = 500 mm, off the table", "set the z translation"),
    "pose z=1µm": (PIECES, (2, BAR.format("1;0;0;0&0;1;0;0&0;0;1;0.001&0;0;0;1")), 2,
                   "at z = 0.001 mm", "set the z translation"),
    "pose last row": (PIECES, (2, BAR.format("1;0;0;0&0;1;0;0&0;0;1;0&0;0;1;1")), 2,
                      "last row is 0;0;1;1, not 0;0;0;1", "end the pose with the row 0;0;0;1"),
    "distance fields": (DIST, (1, "bar_surface_1,stem_surface_4"), 1,
                        "expected '<surface>,<surface>,<value>'", "three comma-separated"),
    "distance part": (DIST, (3, "bar_surface_1,nut_surface_1,3"), 3,
                      "'nut_surface_1' is not a surface of a part", "'<part>_surface_<k>'"),
    "distance surface": (DIST, (3, "bar_surface_1,stem_surface_9,3"), 3,
                         "'stem_surface_9' is not a surface", "k within its surfaces"),
    "distance nan": (DIST, (2, "bar_surface_1,stem_surface_4,nan"), 2,
                     "relation value 'nan' is not a finite number", "as a number"),
    "distance inf": (DIST, (2, "bar_surface_1,stem_surface_4,inf"), 2,
                     "relation value 'inf' is not a finite number", "as a number"),
    "distance word": (DIST, (2, "bar_surface_1,stem_surface_4,far"), 2,
                      "relation value 'far' is not a finite number", "as a number"),
    "distance negative": (DIST, (2, "bar_surface_1,stem_surface_4,-3"), 2,
                          "relation value -3 is negative", "-1 for orthogonal surfaces"),
    "distance conflict": (DIST, (17, "stem_surface_4,bar_surface_1,7"), 17,
                          "is 7 here but 130 on line 2", "one row per pair"),
    "solution part": (SOLS, (2, "stem,bolt,br"), 2, "part 'bolt' is not in assembly.spec",
                      "use the part names"),
    "solution empty name": (SOLS, (1, "bar,stem,br,"), 1, "part '' is not in",
                            "use the part names"),
    "solution repeat": (SOLS, (1, "bar,bar,br"), 1, "a part appears twice",
                        "at most once per line"),
    "solution length": (SOLS, (1, "bar,stem"), 1, "order has 2 of 3 parts",
                        "partial ones in inter_solutions.csv"),
    "dead end part": (DEAD, (1, "bar,nut"), 1, "part 'nut' is not in", "use the part names"),
    "dead end repeat": (DEAD, (1, "br,br"), 1, "a part appears twice", "at most once"),
    "dead end complete": (DEAD, (1, "bar,br,stem"), 1, "dead end lists all 3 parts",
                          "move complete orders to solutions.csv"),
    "dead end prefix": (DEAD, (1, "bar,stem"), 1,
                        "dead end bar,stem is continued by solutions.csv line 1 (bar,stem,br)",
                        "delete one of the two lines"),
    "dead end same set": (DEAD, b"bar,br\nstem,bar\n", 2,
                          "dead end stem,bar is continued by solutions.csv line 1 (bar,stem,br)",
                          "delete one of the two lines"),
    "dead end continued": (DEAD, b"br,stem\nbr\n", 2,
                           "dead end br is continued by inter_solutions.csv line 1 (br,stem)",
                           "a dead end must end where no listed order goes on"),
}  # fmt: skip


def _edit(path: Path, edit: object) -> None:
    if edit is DELETE:
        path.unlink()
    elif isinstance(edit, bytes):
        path.write_bytes(edit)
    else:
        line, text = edit
        lines = path.read_text().splitlines()
        lines[line - 1 : line] = [text]
        path.write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize("case", list(BAD_INPUT))
def test_bad_input_is_one_line_naming_file_line_and_fix(tmp_path, case):
    """A tree with one good and one bad folder: one line naming the bad file, nothing cached."""
    file, edit, line, problem, fix = BAD_INPUT[case]
    root, cache = tmp_path / "raw", tmp_path / "cache"
    export_raw(_bracket_frame(), root / "a_good")
    export_raw(_bracket_frame(), root / "b_bad")
    path = root / "b_bad" / file
    _edit(path, edit)
    before = {p: p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}
    with pytest.raises(RawFormatError) as error:
        import_raw_tree(root, cache)
    where = f"{path}:{line}" if line is not None else f"{path}"
    assert str(error.value) == (
        f"1 of 2 raw folders under {root} is malformed: {error.value.errors[0]}"
    )
    message = str(error.value.errors[0])
    assert message.startswith(f"{where}: ") and "\n" not in message
    problem_part, fix_part = message.removeprefix(f"{where}: ").split("; fix: ")
    assert problem in problem_part and fix in fix_part
    assert not cache.exists()
    assert {p: p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()} == before


def test_a_tree_reports_every_bad_folder_up_to_the_limit(tmp_path):
    root, cache = tmp_path / "raw", tmp_path / "cache"
    for k in range(3):
        export_raw(_bracket_frame(), root / f"good_{k}")
    expected = []
    for k in range(23):
        export_raw(_bracket_frame(), root / f"bad_{k:02d}")
        path = root / f"bad_{k:02d}" / "solutions.csv"
        path.write_text(f"bar,stem,br\nghost{k},bar,br\n")
        expected.append(
            f"{path}:2: part 'ghost{k}' is not in assembly.spec; "
            "fix: use the part names of assembly.spec"
        )
    with pytest.raises(RawTreeError) as error:
        import_raw_tree(root, cache)
    assert [str(e) for e in error.value.errors] == expected
    assert str(error.value).splitlines() == [
        f"23 of 26 raw folders under {root} are malformed: {expected[0]}",
        *expected[1:20],
        "and 3 more malformed folders",
    ]
    assert not cache.exists()
    with pytest.raises(RawTreeError) as error:
        import_raw_folders(find_raw_folders(root), root, limit=2)
    assert str(error.value).splitlines()[1:] == [expected[1], "and 21 more malformed folders"]
