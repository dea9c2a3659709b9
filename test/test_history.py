"""Nothing in the repository speaks of how it was built (docs/development.md, House style).

Every text file git tracks is read line by line; a line that numbers a round of work or an
issue, dates the work, names a run of CI, a machine or a person, points outside the
repository, or tells a constant's tuning history fails the test, reported as ``file:line:
text``. Dates are allowed where a measurement is recorded: ``CHANGELOG.md`` and
``docs/benchmarks.md``.
"""

from __future__ import annotations

from pathlib import Path
import re
import subprocess

import pytest

PROJECT = Path(__file__).resolve().parents[1]

HISTORY: tuple[re.Pattern[str], ...] = tuple(
    re.compile(pattern, re.IGNORECASE)
    for pattern in (
        r"\b(session|stop|turn|round)\s\d+",  # a numbered round of work
        r"\bissue\s\d+",  # an issue by its number
        r"this\s(project's\s)?machine",
        r"\bthe\slead\b(?!'s|\s+of\b)",  # a person (a signal's lead of, lead's: physics)
        r"of\smine",
        r"\bCI\srun\b",  # one run of CI (CI runs everything: allowed)
        r"\.\./shared",  # a folder outside the repository
        r"measured\son\sseed",  # a constant's tuning history
    )
)
"""What no tracked text file may say, anywhere."""

DATE = re.compile(r"\b20[2-9]\d-\d\d-\d\d\b")
"""A date of work (2020 on: an older date is test data, such as YAML's own timestamp example):
only in the files of ``DATES_ALLOWED``."""

DATES_ALLOWED = frozenset({"CHANGELOG.md", "docs/benchmarks.md"})

SKIPPED_SUFFIXES = (".mcap", ".db3", ".png", ".sqlite", ".dbc")
"""Data, not text someone wrote (a DBC is the bus's definition)."""

SKIPPED = frozenset({"LICENSE"})
"""The licence's verbatim text."""


def tracked_text_files() -> list[str]:
    """The repository's tracked files a person writes (data and binaries left out)."""
    listed = subprocess.run(
        ["git", "ls-files", "-z"], cwd=PROJECT, capture_output=True, check=True
    ).stdout.decode()
    names = [name for name in listed.split("\0") if name]
    return [
        name
        for name in names
        if name not in SKIPPED
        and not name.endswith(SKIPPED_SUFFIXES)
        and not (name.startswith(("bags/", "test/")) and name.endswith(".json"))
        and not (name.startswith("bags/") and name.endswith("metadata.yaml"))
    ]


def history_hits(name: str, text: str) -> list[str]:
    """Every line of ``text`` that speaks of how the project was built, as ``file:line: text``."""
    hits = []
    for number, line in enumerate(text.splitlines(), start=1):
        found = any(pattern.search(line) for pattern in HISTORY)
        if not found and name not in DATES_ALLOWED:
            found = DATE.search(line) is not None
        if found:
            hits.append(f"{name}:{number}: {line.strip()}")
    return hits


def test_the_patterns_catch_what_they_are_for() -> None:
    said = {
        "a": "as measured in " + "session" + " 18",
        "b": "blocked in " + "issue" + " 10",
        "c": "on 2026" + "-11-27 it ran",
        "d": "seconds on this " + "machine",
        "e": "as the " + "lead checks it",
        "e2": "seconds on this " + "project's machine",
        "f": "a busy CI " + "run of 27c7062",
        "g": "see ../" + "shared/docs/style.md",
        "h": "measured on " + "seed 1601",
    }
    for key, line in said.items():
        assert history_hits(key, line), line
    assert not history_hits("x", "CI runs everything; cases(seed=1701); round to 3 digits")
    assert not history_hits("x", "the lead of a late p_i; the lead's slope; '2001-12-14'")
    assert not history_hits("CHANGELOG.md", "## 0.1.0 - 2026" + "-11-27")


def test_no_tracked_file_speaks_of_how_the_project_was_built() -> None:
    hits: list[str] = []
    for name in tracked_text_files():
        path = PROJECT / name
        if not path.is_file():
            continue
        data = path.read_bytes()
        if b"\0" in data:
            continue
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError:
            continue
        hits.extend(history_hits(name, text))
    if hits:
        pytest.fail(f"{len(hits)} lines speak of how the project was built:\n" + "\n".join(hits))
