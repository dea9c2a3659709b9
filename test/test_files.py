"""The file doors of brake_hil.files: inputs refused before parsing, outputs before the work."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from brake_hil.errors import OutputError, RigError
from brake_hil.files import (
    MAX_DEPTH,
    check_output_file,
    check_output_folder,
    load_json,
    load_yaml,
    read_text,
)


def test_a_fifo_is_refused_without_being_opened(tmp_path: Path) -> None:
    fifo = tmp_path / "rig.yaml"
    os.mkfifo(fifo)
    with pytest.raises(RigError, match="FIFO"):
        read_text(fifo, "rig file", RigError)  # would block forever if opened


def test_yaml_limits_are_exact(tmp_path: Path) -> None:
    source = tmp_path / "x.yaml"
    deepest = "a: " + "[" * (MAX_DEPTH - 1) + "]" * (MAX_DEPTH - 1)
    assert load_yaml(deepest, source, RigError) is not None
    with pytest.raises(RigError, match="nested deeper"):
        load_yaml("a: " + "[" * MAX_DEPTH + "]" * MAX_DEPTH, source, RigError)
    with pytest.raises(RigError, match="duplicate key 'b' at lines 2 and 3"):
        load_yaml("a:\n  b: 1\n  b: 2\n", source, RigError)
    assert load_yaml("a: 4.0e7", source, RigError) == {"a": 4.0e7}  # YAML 1.2 float


def test_json_refuses_nan_infinity_and_duplicates(tmp_path: Path) -> None:
    path = tmp_path / "m.json"
    for text, fragment in (
        ('{"a": NaN}', "NaN"),
        ('{"a": -Infinity}', "Infinity"),
        ('{"a": 1e999}', "beyond the range"),
        ('{"a": 1, "a": 2}', "duplicate key 'a'"),
        ("[" * 100 + "]" * 100, "nested deeper"),
    ):
        path.write_text(text)
        with pytest.raises(RigError, match=fragment):
            load_json(path, "model file", RigError)


def test_a_link_inside_the_output_folder_is_written_through_one_leading_out_is_not(
    tmp_path: Path,
) -> None:
    folder = tmp_path / "out"
    folder.mkdir()
    (folder / "real.json").write_text("{}")
    (folder / "inside.json").symlink_to(folder / "real.json")
    assert check_output_file(folder / "inside.json") == folder / "inside.json"
    (folder / "outside.json").symlink_to(tmp_path / "elsewhere.json")
    with pytest.raises(OutputError, match="symbolic link"):
        check_output_file(folder / "outside.json")
    with pytest.raises(OutputError, match="symbolic link"):
        check_output_folder(folder, ("outside.json",))
    assert not (tmp_path / "elsewhere.json").exists()


def test_an_output_folder_is_made_and_probed_before_the_work(tmp_path: Path) -> None:
    folder = tmp_path / "new" / "deeper"
    assert check_output_folder(folder) == folder
    assert folder.is_dir() and list(folder.iterdir()) == []  # the probe file is gone
    with pytest.raises(OutputError, match="cannot write here"):
        check_output_file(Path("/proc/brake_hil_probe.json"))
