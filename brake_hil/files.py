"""The file doors every command and node goes through: inputs read, outputs written.

Inputs (rig files, model files, a recording's ``metadata.yaml``) are refused before any
parser sees them when they are not a regular file (a FIFO would block forever), larger than
their kind's limit, binary, or not UTF-8. Text is then parsed strictly:

* YAML (:func:`load_yaml`): no anchors, aliases or merge keys (a rig file needs none, and an
  alias bomb expands to gigabytes), no nesting deeper than :data:`MAX_DEPTH`, no scalar
  longer than :data:`MAX_SCALAR_CHARS` (a 400-digit integer), no key twice in one mapping
  (the message names the key and both lines), YAML 1.2 floats (``4.0e7`` is a float).
* JSON (:func:`load_json`): no ``NaN``/``Infinity``, no duplicate key, the same depth and
  scalar limits.

Outputs (:func:`check_output_file`, :func:`check_output_folder`, :func:`output_file`) are
checked before the work starts (a folder that cannot be made or written is found in
milliseconds, not after a ten-minute diagnosis), and nothing is written through a symbolic
link that leads out of the output folder.

Every refusal is the given :class:`~brake_hil.errors.BrakeHilError` subclass (or
:class:`~brake_hil.errors.OutputError`) with a one-line message that starts with the path.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable
import json
import math
import os
from pathlib import Path
import re
import stat
import tempfile
from typing import Any, Final

import yaml

from brake_hil.errors import BrakeHilError, OutputError

__all__ = [
    "MAX_DEPTH",
    "MAX_SCALAR_CHARS",
    "RIG_FILE_MAX_BYTES",
    "check_input_file",
    "check_output_file",
    "check_output_folder",
    "load_json",
    "load_yaml",
    "output_file",
    "read_text",
]

RIG_FILE_MAX_BYTES: Final = 1 << 20
"""Largest rig or model file read (1 MiB; a rig file is about 2 kB)."""
MAX_DEPTH: Final = 16
"""Deepest nesting of mappings and lists in a rig or model file (a rig file has 3 levels)."""
MAX_SCALAR_CHARS: Final = 256
"""Longest scalar (number or string) in a rig or model file."""

ErrorType = Callable[[str], BrakeHilError]

_KIND: Final = {
    stat.S_IFIFO: "a FIFO (named pipe)",
    stat.S_IFSOCK: "a socket",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
}


def _one_line(err: BaseException) -> str:
    return " ".join(str(err).split()).rstrip(".") or type(err).__name__


def check_input_file(path: Path, what: str, max_bytes: int, error: ErrorType) -> int:
    """Refuse ``path`` unless it is a regular file of at most ``max_bytes``; return its size.

    Args:
        path: the file (a symbolic link is followed).
        what: what the file should be, for the message (e.g. ``"rig file"``).
        max_bytes: size limit (bytes).
        error: the error class to raise.

    Raises:
        BrakeHilError: ``error`` naming the path and the problem.
    """
    try:
        info = path.stat()
    except FileNotFoundError as err:
        raise error(f"{path}: cannot read {what}: no such {what}") from err
    except OSError as err:
        raise error(f"{path}: cannot read {what}: {err.strerror or _one_line(err)}") from err
    if stat.S_ISDIR(info.st_mode):
        raise error(f"{path}: is a directory, not a {what}")
    if not stat.S_ISREG(info.st_mode):
        kind = _KIND.get(stat.S_IFMT(info.st_mode), "not a regular file")
        raise error(f"{path}: is {kind}, not a {what} (only regular files are read)")
    if info.st_size > max_bytes:
        raise error(
            f"{path}: {what} of {info.st_size} bytes is larger than the limit of {max_bytes} bytes"
        )
    return info.st_size


def read_text(path: Path, what: str, error: ErrorType, max_bytes: int = RIG_FILE_MAX_BYTES) -> str:
    """The UTF-8 text of a regular file of at most ``max_bytes``; refuse binary files.

    Raises:
        BrakeHilError: ``error`` when the file is missing, not regular, too large, binary
            (holds a NUL byte) or not UTF-8.
    """
    check_input_file(path, what, max_bytes, error)
    try:
        with path.open("rb") as stream:
            data = stream.read(max_bytes + 1)
    except OSError as err:
        raise error(f"{path}: cannot read {what}: {err.strerror or _one_line(err)}") from err
    if len(data) > max_bytes:
        raise error(f"{path}: {what} is larger than the limit of {max_bytes} bytes")
    if b"\0" in data:
        raise error(f"{path}: a binary file (NUL byte at offset {data.index(0)}), not a {what}")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data[: err.start].count(b"\n") + 1
        raise error(
            f"{path}: {what} is not UTF-8 text: byte 0x{data[err.start]:02x} at line {line}"
        ) from err


class _StrictLoader(yaml.SafeLoader):
    """SafeLoader that reads ``4.0e7`` as a float (YAML 1.2) and refuses duplicate keys."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Hashable, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)  # type: ignore[no-untyped-call]
            if not isinstance(key, Hashable):
                continue  # SafeLoader's own "unhashable key" error follows
            line = key_node.start_mark.line + 1
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    problem=f"duplicate key {key!r} at lines {seen[key]} and {line}"
                )
            seen[key] = line
        return super().construct_mapping(node, deep=deep)


_StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:\d+\.?\d*|\.\d+)[eE][-+]?\d+$"),
    list("-+0123456789."),
)


def _scan_yaml(text: str, source: Path, error: ErrorType, max_scalar: int) -> None:
    """Refuse anchors, aliases, merge keys, deep nesting and long scalars, before composing.

    The event parser is iterative, so even 50 000 levels of nesting cost no recursion.
    """
    depth = 0
    for event in yaml.parse(text, Loader=yaml.SafeLoader):
        line = event.start_mark.line + 1 if event.start_mark is not None else 0
        if isinstance(event, yaml.AliasEvent):
            raise error(f"{source}: line {line}: YAML alias '*{event.anchor}' refused")
        if (anchor := getattr(event, "anchor", None)) is not None:
            raise error(f"{source}: line {line}: YAML anchor '&{anchor}' refused")
        if isinstance(event, yaml.CollectionStartEvent):
            depth += 1
            if depth > MAX_DEPTH:
                raise error(f"{source}: line {line}: nested deeper than {MAX_DEPTH} levels")
        elif isinstance(event, yaml.CollectionEndEvent):
            depth -= 1
        elif isinstance(event, yaml.ScalarEvent):
            if event.value == "<<" and event.style is None:
                raise error(f"{source}: line {line}: YAML merge key '<<' refused")
            if len(event.value) > max_scalar:
                raise error(
                    f"{source}: line {line}: a value of {len(event.value)} characters is too "
                    f"long (at most {max_scalar})"
                )


def load_yaml(
    text: str, source: Path, error: ErrorType, max_scalar: int = MAX_SCALAR_CHARS
) -> object:
    """Parse ``text`` as strict YAML (module docstring); ``error`` names ``source``.

    Args:
        text: the document.
        source: its file (for the message).
        error: the error class to raise.
        max_scalar: the longest scalar accepted (characters).

    Raises:
        BrakeHilError: ``error`` with the parser's first line, or the refusal.
    """
    try:
        _scan_yaml(text, source, error, max_scalar)
        return yaml.load(text, Loader=_StrictLoader)  # noqa: S506 (a SafeLoader)
    except BrakeHilError:
        raise
    except yaml.YAMLError as err:
        problem = getattr(err, "problem", None) or _one_line(err).split(" in ")[0]
        mark = getattr(err, "problem_mark", None) or getattr(err, "context_mark", None)
        where = f" (line {mark.line + 1})" if mark is not None and "line" not in problem else ""
        raise error(f"{source}: not valid YAML: {problem}{where}") from err
    except (ValueError, RecursionError, OverflowError) as err:
        raise error(f"{source}: not valid YAML: {_one_line(err)}") from err


def _refuse_constant(name: str) -> float:
    raise ValueError(f"{name} is not a number a model file may hold")


def _float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text} is beyond the range of a float")
    return value


def _int(text: str) -> int:
    if len(text.lstrip("-")) > 20:
        raise ValueError(f"an integer of {len(text)} digits")
    return int(text)


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    result: dict[str, Any] = {}
    for key, value in pairs:
        if key in result:
            raise ValueError(f"duplicate key {key!r}")
        result[key] = value
    return result


def load_json(path: Path, what: str, error: ErrorType) -> object:
    """Read a JSON file strictly: no NaN/Infinity, no duplicate keys, no deep nesting.

    Raises:
        BrakeHilError: ``error`` naming the file and the problem.
    """
    text = read_text(path, what, error)
    depth = 0
    for char in text:  # JSON's parser recurses; count brackets first (strings rarely hold any)
        depth += (char in "[{") - (char in "]}")
        if depth > MAX_DEPTH:
            raise error(f"{path}: not valid JSON: nested deeper than {MAX_DEPTH} levels")
    try:
        document = json.loads(
            text,
            parse_constant=_refuse_constant,
            parse_int=_int,
            parse_float=_float,
            object_pairs_hook=_no_duplicates,
        )
    except json.JSONDecodeError as err:
        raise error(f"{path}: not valid JSON: {err.msg} (line {err.lineno})") from err
    except (ValueError, RecursionError) as err:
        raise error(f"{path}: not valid JSON: {_one_line(err)}") from err
    return document


def finite(value: object) -> bool:
    """Whether ``value`` is a finite int or float (not a bool)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def _probe_folder(folder: Path, for_path: Path) -> None:
    """Make ``folder`` (and parents) and prove a file can be created in it."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        if not folder.is_dir():
            raise OutputError(f"{for_path}: {folder} is not a folder")
        handle, name = tempfile.mkstemp(prefix=".brake-hil-probe-", dir=folder)
        os.close(handle)
        os.unlink(name)
    except OutputError:
        raise
    except OSError as err:
        problem = err.strerror or _one_line(err)
        raise OutputError(f"{for_path}: cannot write here: {problem}") from err


def _refuse_escaping_link(path: Path, folder: Path) -> None:
    """Refuse ``path`` when it is a symbolic link that leads out of ``folder``."""
    if not path.is_symlink():
        return
    target = path.resolve()
    if not target.is_relative_to(folder.resolve()):
        raise OutputError(
            f"{path}: a symbolic link to {target}, outside {folder}: refused, not written through"
        )


def check_output_file(path: Path) -> Path:
    """Check, before any work, that the file ``path`` can be written; return it.

    Its folder is made if missing and a file is created and removed there; ``path`` itself
    must not be a folder, nor a symbolic link that leads out of its folder.

    Raises:
        OutputError: naming the path and the problem.
    """
    folder = path.parent
    _refuse_escaping_link(path, folder)
    if path.is_dir():
        raise OutputError(f"{path}: is a folder, a file name is needed")
    if path.exists() and not path.is_file():
        raise OutputError(f"{path}: exists and is not a regular file")
    _probe_folder(folder, path)
    return path


def check_output_folder(folder: Path, names: tuple[str, ...] = ()) -> Path:
    """Check, before any work, that ``folder`` can be made and written; return it.

    Args:
        folder: the output folder.
        names: files the command will write in it; each must not be a folder or a symbolic
            link that leads out of ``folder``.

    Raises:
        OutputError: naming the folder (or file) and the problem.
    """
    if folder.exists() and not folder.is_dir():
        raise OutputError(f"{folder}: exists and is not a folder")
    _probe_folder(folder, folder)
    for name in names:
        output_file(folder, name)
    return folder


def output_file(folder: Path, name: str) -> Path:
    """``folder / name``, refused when it is a folder or a link leading out of ``folder``.

    Raises:
        OutputError: naming the file and the problem.
    """
    path = folder / name
    _refuse_escaping_link(path, folder)
    if path.is_dir():
        raise OutputError(f"{path}: is a folder, the command writes a file here")
    return path
