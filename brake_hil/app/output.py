"""The output door: a command's files checked before its work, and its JSON written.

The checks are :mod:`brake_hil.files`'; they run before the work starts (an unwritable
``--json`` or ``--out`` costs milliseconds, not a whole diagnosis) and again as each file is
written (never through a symbolic link that leads out of the output folder).
"""

from __future__ import annotations

import json
from pathlib import Path

from brake_hil.files import check_output_file, check_output_folder

__all__ = ["check_outputs", "write_json"]


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
