"""The output door: a command's files checked before its work, and its JSON written.

The checks are :mod:`brake_hil.files`'; they run once the inputs are opened and checked and
before the work starts (an unwritable ``--json`` or ``--out`` costs milliseconds, not a whole
diagnosis) and again as each file is written (never through a symbolic link that leads out
of the output folder). A command refused after its folders were made leaves none behind
(:func:`removed_if_refused`).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
import json
import os
from pathlib import Path

from brake_hil.files import check_output_file, check_output_folder

__all__ = ["check_outputs", "removed_if_refused", "write_json"]


def _missing(folder: Path) -> list[Path]:
    """``folder`` and each of its parents that does not exist yet, deepest first."""
    missing = []
    here = Path(os.path.abspath(folder))
    while not os.path.lexists(here) and here != here.parent:
        missing.append(here)
        here = here.parent
    return missing


@contextmanager
def removed_if_refused(*folders: Path | None) -> Iterator[None]:
    """On an error in the block, remove those of ``folders`` (and their parents) it made.

    Only folders missing when the block began and empty when it failed are removed: a
    refused command leaves no empty output folder, and never loses a file.
    """
    made = [m for folder in folders if folder is not None for m in _missing(folder)]
    try:
        yield
    except BaseException:
        for folder in sorted(set(made), key=lambda f: len(f.parts), reverse=True):
            try:
                folder.rmdir()
            except OSError:
                pass
        raise


def check_outputs(
    *files: Path | None, folder: Path | None = None, names: tuple[str, ...] = ()
) -> None:
    """Check, before the work, that every output can be written.

    Args:
        files: output files (``None``: not asked for).
        folder: an output folder, made if missing.
        names: the files the command writes in ``folder``.

    Raises:
        OutputError: an output cannot be written (the message names it).
    """
    for path in files:
        if path is not None:
            check_output_file(path)
    if folder is not None:
        check_output_folder(folder, names)


def write_json(path: Path | None, document: object) -> Path | None:
    """Write ``document`` as indented JSON to ``path`` (its folder made); ``None``: nothing.

    Args:
        path: the file to write, or ``None``.
        document: JSON-ready data.

    Returns:
        ``path``.
    """
    if path is None:
        return None
    check_output_file(path)
    path.write_text(json.dumps(document, indent=2) + "\n", encoding="utf-8")
    return path
