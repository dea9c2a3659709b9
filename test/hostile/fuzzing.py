"""The fuzz suite's strategies and its one-example checks, shared by the test and the benchmark.

:func:`recording_example` writes the good recording with random damage and runs ``compare``
or ``characterize`` on it; :func:`rig_example` does the same to the rig file and runs
``compare``. Each returns the :class:`~test.hostile.harness.Run`; its outcome is one of the
harness's. An answer (exit 0) must be finite; where the damage leaves the data as good as
whole (a few isolated messages dropped, a stamp moved by under half a period, a rig file
that loads to the same rig) it must also match the undamaged answer.
"""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache
from pathlib import Path
import re
import tempfile
from typing import Any

from hypothesis import strategies as st

from brake_hil.errors import BrakeHilError
from brake_hil.physics.rig import load_rig
from test.hostile import damage
from test.hostile.harness import Run, run_cli

TOPICS = 4  # p_i, p_b, F_k, x_c in the good recording
index = st.integers(0, 10**6)
topic = st.integers(0, TOPICS - 1)
odd_values = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e30, -1e30, 0.0, 5.0e7, -2.0e5, 1e-30]),
)
message_damage = st.one_of(
    st.tuples(st.just("drop"), topic, index, st.integers(1, 40)),
    st.tuples(st.just("duplicate"), topic, index),
    st.tuples(
        st.just("move_stamp"),
        topic,
        index,
        st.one_of(
            st.integers(-3_000_000, 3_000_000),
            st.sampled_from([-(10**18), 10**12, 10**10, 1, -1]),
        ),
    ),
    st.tuples(
        st.just("shift"),
        topic,
        index,
        st.sampled_from([-1_000_000, 2_000_000, 6_000_000, 100_000_000, 10_000_000_000]),
    ),
    st.tuples(st.just("values"), topic, index, st.integers(1, 50), odd_values),
)
file_damage = st.one_of(
    st.tuples(st.just("truncate"), st.floats(0.0, 1.0)),
    st.tuples(
        st.just("flip"),
        st.lists(st.tuples(st.floats(0.0, 1.0), st.integers(1, 255)), min_size=1, max_size=8),
    ),
)
recording_damage = st.tuples(
    st.lists(message_damage, min_size=0, max_size=3),
    st.one_of(st.none(), file_damage),
    st.sampled_from(["compare", "characterize"]),
)


@lru_cache(maxsize=1)
def baseline() -> dict[str, Any]:
    """compare's JSON on the undamaged recording."""
    with tempfile.TemporaryDirectory() as folder:
        bag = damage.good_messages().write(Path(folder) / "good")
        out = Path(folder) / "good.json"
        run = run_cli(["compare", str(bag), "--rig", str(damage.GOOD_RIG), "--json", str(out)])
        assert run.outcome == "answer", run.describe()
        document = damage.read_json(out)
    assert isinstance(document, dict)
    return document


def _benign(ops: list[tuple[Any, ...]]) -> bool:
    """Damage that leaves the data as good as whole."""
    dropped = 0
    for op in ops:
        if op[0] == "drop" and op[3] <= 3:
            dropped += op[3]
        elif op[0] == "move_stamp" and abs(op[3]) < 400_000:
            continue
        else:
            return False
    return dropped <= 9


def _check(out: Path, whole: bool, command: str) -> str | None:
    if not out.is_file():
        return "exit 0 but no JSON written"
    document = damage.read_json(out)
    if (problem := damage.finite_metrics(document)) is not None:
        return f"not finite: {problem}"
    assert isinstance(document, dict)
    if command == "compare" and whole:
        return damage.close_to(document["metrics"], baseline()["metrics"])
    return None


def recording_example(
    ops: list[tuple[Any, ...]], file_op: tuple[Any, ...] | None, command: str, folder: Path
) -> Run:
    """Damage the good recording as ``ops`` and ``file_op`` say, then run ``command``."""
    messages = damage.good_messages()
    specs = list(messages.topics)
    for op in ops:
        spec = specs[op[1]]
        if op[0] == "drop":
            messages = damage.drop(messages, spec, op[2], op[3])
        elif op[0] == "duplicate":
            messages = damage.duplicate(messages, spec, op[2])
        elif op[0] == "move_stamp":
            messages = damage.move_stamp(messages, spec, op[2], op[3])
        elif op[0] == "shift":
            messages = damage.shift_stamps(messages, spec, op[2], op[3])
        else:
            messages = damage.set_values(messages, spec, op[2], op[3], op[4])
    bag = messages.write(folder / "bag")
    if file_op is not None and file_op[0] == "truncate":
        damage.truncate(bag, file_op[1])
    elif file_op is not None:
        damage.flip_bytes(bag, file_op[1])
    out = folder / "answer.json"
    whole = file_op is None and _benign(ops)
    return run_cli(
        [command, str(bag), "--rig", str(damage.GOOD_RIG), "--json", str(out)],
        lambda _stdout: _check(out, whole, command),
    )


# ----------------------------------------------------------------------------- rig files

RIG_TEXT = damage.GOOD_RIG.read_text(encoding="utf-8")
RIG_LINES = RIG_TEXT.splitlines()
_NUMBER = re.compile(r"(?<=: )[-+0-9.eE]+")
yaml_values = st.one_of(
    st.sampled_from(
        [
            ".nan",
            ".inf",
            "-.inf",
            "~",
            "null",
            "true",
            "0",
            "-1",
            "0x1F",
            "1_000",
            "1e400",
            "9" * 400,
            "'3.0'",
            "[1, 2]",
            "{a: 1}",
            "&a 1",
            "*a",
            "!!binary aGVsbG8=",
            "!!python/object:os.system ls",
            "-".join(("2001", "12", "14")),  # a YAML timestamp
            "1.0e-300",
            "<<",
            "''",
            "{",
            "]",
            '"\\x00"',
            "! 1",
            "!!float 1",
            "!!int 1.5",
            "|\n    text",
        ]
    ),
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
    st.integers().map(str),
    st.text(max_size=12),
)
rig_damage = st.lists(
    st.one_of(
        st.tuples(st.just("value"), st.integers(0, 200), yaml_values),
        st.tuples(st.just("delete"), st.integers(0, 200)),
        st.tuples(st.just("repeat"), st.integers(0, 200)),
        st.tuples(st.just("indent"), st.integers(0, 200), st.integers(-4, 4)),
        st.tuples(st.just("insert"), st.integers(0, 200), st.text(max_size=30)),
        st.tuples(
            st.just("tolerance"),
            st.sampled_from(
                ["caliper.stiffness", "seal.loss_factor", "washers", "nonsense", "fluid.density"]
            ),
            yaml_values,
        ),
    ),
    min_size=1,
    max_size=3,
)


def damaged_rig_text(ops: list[tuple[Any, ...]]) -> str:
    """The good rig file's text damaged as ``ops`` say."""
    lines = list(RIG_LINES)
    tolerances: list[str] = []
    for op in ops:
        where = op[1] % len(lines) if op[0] != "tolerance" and lines else 0
        if op[0] == "value":
            line = lines[where]
            if _NUMBER.search(line):
                lines[where] = _NUMBER.sub(lambda _m, new=op[2]: new, line, count=1)
            elif ": " in line:
                lines[where] = line.split(": ", 1)[0] + ": " + op[2]
        elif op[0] == "delete" and lines:
            del lines[where]
        elif op[0] == "repeat" and lines:
            lines.insert(where, lines[where])
        elif op[0] == "indent" and lines:
            line = lines[where]
            lines[where] = " " * max(0, len(line) - len(line.lstrip()) + op[2]) + line.lstrip()
        elif op[0] == "insert":
            lines.insert(where, op[2])
        elif op[0] == "tolerance":
            tolerances.append(f"{op[1]}: {op[2]}")
    text = "\n".join(lines) + "\n"
    if tolerances:
        text += "  tolerances: {" + ", ".join(tolerances) + "}\n"
    return text


def _same_rig(path: Path) -> bool:
    try:
        damaged = load_rig(path)
    except BrakeHilError:
        return False
    good = load_rig(damage.GOOD_RIG)
    return replace(damaged, source="") == replace(good, source="")


def rig_example(ops: list[tuple[Any, ...]], folder: Path) -> Run:
    """Damage the good rig file as ``ops`` say, then run ``compare`` with it."""
    rig = folder / "rig.yaml"
    rig.write_text(damaged_rig_text(ops), encoding="utf-8", errors="surrogatepass")
    bag = folder / "good"
    if not bag.exists():
        damage.good_messages().write(bag)
    out = folder / "answer.json"
    out.unlink(missing_ok=True)

    def check(_stdout: str) -> str | None:
        if not out.is_file():
            return "exit 0 but no JSON written"
        document = damage.read_json(out)
        if (problem := damage.finite_metrics(document)) is not None:
            return f"not finite: {problem}"
        if _same_rig(rig):
            assert isinstance(document, dict)
            return damage.close_to(document["metrics"], baseline()["metrics"])
        return None

    return run_cli(["compare", str(bag), "--rig", str(rig), "--json", str(out)], check)
