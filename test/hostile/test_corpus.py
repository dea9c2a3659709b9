"""Every input of the hostile corpus through compare, characterize and diagnose.

Refused inputs must give exit 2 and one line naming the problem (each case's fragments),
within seconds: a refused output is found before the work starts. Accepted inputs must give
the right answer (close to the undamaged recording's; tolerance 0 held fixed by diagnose).
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest

from brake_hil.errors import BrakeHilError
from brake_hil.live.model_file import load_model
from test.hostile import corpus, damage
from test.hostile.harness import run_cli

REFUSAL_S = 5.0
"""Longest a refusal may take (CPU s): every door refuses before the work."""


def test_every_hostile_input_is_refused_in_one_line_or_answered_right(tmp_path: Path) -> None:
    cases = corpus.build(tmp_path / "corpus")
    counts: Counter[str] = Counter()
    failures = []
    for case in cases:
        for command in case.commands:
            argv = case.argv(command, tmp_path / "answers")
            answer = Path(argv[argv.index("--out" if command == "diagnose" else "--json") + 1])

            def check(
                stdout: str,
                case: corpus.Case = case,
                answer: Path = answer,
                command: str = command,
            ) -> str | None:
                if command != "diagnose":
                    problem = damage.finite_metrics(damage.read_json(answer))
                    if problem is not None:
                        return problem
                return case.check(stdout, answer) if case.check is not None else None

            run = run_cli(argv, check, deadline_s=60.0 if command == "diagnose" else 10.0)
            counts[run.outcome] += 1
            expected = {"either": ("answer", "refused")}.get(case.expect, (case.expect,))
            missing = [f for f in case.fragments if f not in run.stderr]
            slow = run.outcome == "refused" and run.cpu_seconds > REFUSAL_S
            if run.outcome not in expected or (run.outcome == "refused" and missing) or slow:
                failures.append(f"{case.name}: {run.describe()}\nmissing {missing}")
    print(dict(counts))
    assert not failures, "\n\n".join(failures)
    assert counts["refused"] >= 50


@pytest.mark.parametrize(
    ("name", "content", "fragment"),
    [
        (
            "nan_washers.yaml",
            damage.GOOD_RIG.read_text().replace("washers: 1", "washers: .nan"),
            "finite",
        ),
        (
            "latin1.yaml",
            damage.GOOD_RIG.read_bytes().replace(b"name: ", b"name: \xe9", 1),
            "UTF-8",
        ),
        ("nan.json", '{"format": 1, "parameters": {"k": NaN}}', "NaN"),
        ("huge.json", '{"format": 1, "parameters": {"k": 1e400}}', "beyond the range"),
    ],
)
def test_a_hostile_model_file_is_refused_in_one_line_naming_it(
    tmp_path: Path, name: str, content: str | bytes, fragment: str
) -> None:
    """caliper_model and regress load model files through the same doors."""
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    with pytest.raises(BrakeHilError) as caught:
        load_model(path)
    message = str(caught.value)
    assert message.startswith(str(path)) and "\n" not in message and fragment in message
