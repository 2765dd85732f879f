"""The raw importer on fuzzed folders (tests/data/raw_fuzz.py): every folder is imported or
refused in one line naming the file and the fix; none gives a traceback or hangs. The fast suite
runs a handful of seeded folders and the ±1.7e308 coordinates of a hand-made one, the slow test
100 folders, printing the counts."""

from pathlib import Path

import numpy as np
import pytest
from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.utils import instantiate
from raw_fuzz import fuzz_counts, outcome

from grace import CONF_DIR
from grace.cli.schemas import register_schemas
from grace.data.raw_format import (
    ASSEMBLY_FILE,
    DISTANCES_FILE,
    MAX_DISTANCE_MM,
    WORKSPACE_MM,
    RawFormatError,
    export_raw,
    import_raw,
    read_assembly,
)


@pytest.fixture(scope="module")
def bases(tmp_path_factory) -> list[Path]:
    """Raw folders of generated assemblies of 5, 6 and 7 parts (brackets, dead ends) of the real
    simulator."""
    register_schemas()
    GlobalHydra.instance().clear()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        simulator = instantiate(compose(config_name="config").simulator)
    GlobalHydra.instance().clear()
    root = tmp_path_factory.mktemp("raw")
    out = []
    for size in (5, 6, 7):
        sample = simulator.sample(size, np.random.default_rng(size))
        sample.assembly.name = f"A{size}"
        export_raw(sample, root / sample.assembly.name)
        out.append(root / sample.assembly.name)
    return out


def test_the_unfuzzed_folders_import(bases):
    assert [outcome(base) for base in bases] == ["imported"] * 3


def test_fuzzed_folders_are_imported_or_refused_in_one_line(bases, tmp_path):
    counts, bad = fuzz_counts(bases, tmp_path, count=12, seed=0)
    assert bad == {}
    assert counts["one line"] > 0


@pytest.mark.slow
def test_a_hundred_fuzzed_folders_give_no_traceback_and_no_hang(bases, tmp_path):
    counts, bad = fuzz_counts(bases, tmp_path, count=100, seed=2024)
    print(f"100 fuzzed raw folders: {dict(counts)}")
    assert bad == {}
    assert counts["imported"] + counts["one line"] == 100


@pytest.mark.parametrize("x", ["1.7e308", "-1.7e308", "2000.5"])
def test_a_position_outside_the_workspace_is_one_line_in_import_and_plan(bases, tmp_path, x):
    folder = tmp_path / "far"
    folder.mkdir()
    for file in bases[0].iterdir():
        (folder / file.name).write_bytes(file.read_bytes())
    spec = folder / ASSEMBLY_FILE
    lines = spec.read_text().splitlines()
    name, kind, pose = lines[1].split()
    rows = pose.split("&")
    cells = rows[0].split(";")
    rows[0] = ";".join([*cells[:3], x])
    lines[1] = f"{name} {kind} {'&'.join(rows)}"
    spec.write_text("\n".join(lines) + "\n")
    message = (
        f"{spec}:2: pose puts the part at x = {float(x):.6g} mm, outside the cell's workspace "
        f"(|x|, |y| ≤ {WORKSPACE_MM:.0f} mm); fix: write positions in millimetres in the world "
        "frame of docs/world.md (origin at the work-area centre)"
    )
    for read in (import_raw, read_assembly):  # the importer, and task=plan's reader
        with pytest.raises(RawFormatError) as error:
            read(folder)
        assert str(error.value) == message
    with pytest.raises(RawFormatError, match="outside the cell's workspace"):
        read_assembly(spec)  # a lone assembly.spec


def test_a_distance_beyond_the_workspace_is_one_line(bases, tmp_path):
    folder = tmp_path / "wide"
    folder.mkdir()
    for file in bases[0].iterdir():
        (folder / file.name).write_bytes(file.read_bytes())
    distances = folder / DISTANCES_FILE
    first, *rest = distances.read_text().splitlines()
    a, b, _ = first.split(",")
    distances.write_text("\n".join([f"{a},{b},1e300", *rest]) + "\n")
    with pytest.raises(RawFormatError) as error:
        import_raw(folder)
    assert str(error.value) == (
        f"{distances}:1: relation value 1e300 is beyond the cell's workspace; fix: write a "
        f"distance from 0 to {MAX_DISTANCE_MM:.0f} mm, or -1 for orthogonal surfaces"
    )
