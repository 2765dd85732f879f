import json
import math
import os

import pytest

from grace.data import atomic
from grace.data.atomic import write_bytes_atomic, write_json_atomic, write_text_atomic


def test_write_creates_folders_and_honours_the_umask(tmp_path):
    path = tmp_path / "a" / "b" / "f.txt"
    write_text_atomic(path, "héllo\n")
    assert path.read_bytes() == "héllo\n".encode()
    mask = os.umask(0)
    os.umask(mask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~mask
    assert [p.name for p in path.parent.iterdir()] == ["f.txt"]


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path, monkeypatch):
    path = tmp_path / "f.bin"
    path.write_bytes(b"old")

    def crash(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(atomic.os, "replace", crash)
    with pytest.raises(OSError, match="disk full"):
        write_bytes_atomic(path, b"new")
    assert path.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["f.bin"]


def _strict(constant: str):
    raise ValueError(f"{constant} is not JSON")


def test_json_is_strict_and_non_finite_numbers_are_null(tmp_path):
    """Python's json writes NaN and -Infinity, which strict parsers reject."""
    path = tmp_path / "r.json"
    write_json_atomic(path, {"auc": math.nan, "feasibility": -math.inf, "x": [1.5, (math.inf, 2)]})
    assert json.loads(path.read_text(), parse_constant=_strict) == {
        "auc": None,
        "feasibility": None,
        "x": [1.5, [None, 2]],
    }
