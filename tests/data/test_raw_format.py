from pathlib import Path

import numpy as np
import pytest
from hydra.utils import instantiate

from grace.data.raw_format import (
    RAW_FILES,
    RawFormatError,
    export_raw,
    find_raw_folders,
    format_number,
    import_raw,
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


def test_export_layout(tmp_path):
    sample = _bracket_frame()
    export_raw(sample, tmp_path / "frame")
    spec = (tmp_path / "frame" / "assembly.spec").read_text().splitlines()
    assert spec[0] == "begin Pieces" and spec[-1] == "end Pieces"
    assert spec[2] == "stem item_profile_200 1;0;0;0.25&0;1;0;120&0;0;1;0&0;0;0;1"
    assert (tmp_path / "frame" / "solutions.csv").read_text() == "bar,stem,br\nstem,bar,br\n"
    assert (tmp_path / "frame" / "inter_solutions.csv").read_text() == ""
    rows = (tmp_path / "frame" / "distances.csv").read_text().splitlines()
    assert "bar_surface_1,stem_surface_2,12.5" in rows
    names = sample.assembly.surface_names()
    assert len(rows) == len(set(rows))
    assert all(r.split(",")[0] in names and r.split(",")[1] in names for r in rows)


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


def test_missing_inter_solutions_is_optional(tmp_path):
    export_raw(_bracket_frame(), tmp_path / "x")
    (tmp_path / "x" / "inter_solutions.csv").unlink()
    assert import_raw(tmp_path / "x").truth.n_orders() == 2


MALFORMED = [
    ("assembly.spec", None, "missing file"),
    ("assembly.spec", (2, "bar item_profile_300 1;0;0&0;1;0;0&0;0;1;0&0;0;0;1"), "4×4"),
    (
        "assembly.spec",
        (2, "bar item_profile_300 1;0;0;x&0;1;0;0&0;0;1;0&0;0;0;1"),
        "not a finite number",
    ),
    (
        "assembly.spec",
        (3, "stem item_profile_400 1;0;0;0&0;1;0;120&0;0;1;0&0;0;0;1"),
        "unknown part type",
    ),
    ("assembly.spec", (1, "begin Parts"), "begin Pieces"),
    ("distances.csv", (1, "bar_surface_1,stem_surface_9,3"), "stem_surface_9"),
    ("distances.csv", (1, "bar_surface_1,nut_surface_1,3"), "nut_surface_1"),
    ("distances.csv", (1, "bar_surface_1,stem_surface_4"), "three comma-separated"),
    ("solutions.csv", (2, "stem,bolt,br"), "'bolt'"),
    ("solutions.csv", (1, "bar,stem"), "2 of 3 parts"),
    ("inter_solutions.csv", (1, "bar,bar"), "twice"),
]


@pytest.mark.parametrize(("file", "edit", "needle"), MALFORMED)
def test_malformed_folder_names_file_and_line(tmp_path, file, edit, needle):
    folder = tmp_path / "frame"
    export_raw(_bracket_frame(), folder)
    (folder / "inter_solutions.csv").write_text("stem\n")
    path = folder / file
    if edit is None:
        path.unlink()
        where = f"{path}: "
    else:
        line, text = edit
        lines = path.read_text().splitlines() or [""]
        lines[line - 1] = text
        path.write_text("\n".join(lines) + "\n")
        where = f"{path}:{line}: "
    before = sorted(p.name for p in folder.iterdir())
    with pytest.raises(RawFormatError) as error:
        import_raw(folder)
    message = str(error.value)
    assert message.startswith(where) and needle in message and "fix:" in message
    assert "\n" not in message
    assert sorted(p.name for p in folder.iterdir()) == before


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
