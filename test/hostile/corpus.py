"""A reproducible corpus of hostile inputs of every kind, made from the good files.

``python -m test.hostile.corpus DIR`` writes it; :func:`build` returns the cases. Each
:class:`Case` says which commands to run, what it expects (``refused``: exit 2 with one line
holding every fragment; ``answer``: exit 0, checked by ``check`` when given; ``either``: an
answer or a one-line refusal, for inputs whose fate depends on the machine, e.g. permissions
under root) and how long a refusal may take. No case depends on randomness.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
import os
from pathlib import Path
import sys

from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from brake_hil.topics import BLOCK_FORCE, BORE_PRESSURE, MASTER_CYLINDER_PRESSURE
from test.hostile import damage

COMMANDS = ("compare", "characterize", "diagnose")


@dataclass(frozen=True)
class Case:
    """One hostile input and what ``brake-hil`` must do with it."""

    name: str
    recording: Path
    rig: Path
    expect: str  # refused, answer, either
    fragments: tuple[str, ...] = ()
    commands: tuple[str, ...] = COMMANDS
    json: Path | None = None  # --json of compare/characterize (None: a file in the case folder)
    out: Path | None = None  # --out of diagnose (None: a folder in the case folder)
    check: Callable[[str, Path], str | None] | None = field(default=None, compare=False)

    def argv(self, command: str, folder: Path) -> list[str]:
        """The command line of ``command`` on this case, its outputs under ``folder``."""
        argv = [command, str(self.recording), "--rig", str(self.rig)]
        if command == "diagnose":
            return [*argv, "--out", str(self.out or folder / f"{self.name}.diagnosis")]
        return [*argv, "--json", str(self.json or folder / f"{self.name}.{command}.json")]


def _rig_variant(folder: Path, name: str, text: str | bytes) -> Path:
    path = folder / f"{name}.yaml"
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text, encoding="utf-8")
    return path


def _rig_cases(folder: Path, good_bag: Path) -> list[Case]:
    text = damage.GOOD_RIG.read_text(encoding="utf-8")

    def washers(value: str) -> str:
        return text.replace("  washers: 1\n", f"  washers: {value}\n")

    def refused(name: str, content: str | bytes, *fragments: str) -> Case:
        return Case(name, good_bag, _rig_variant(folder, name, content), "refused", fragments)

    bomb = ["  a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1]"] + [
        f"  {chr(98 + i)}: &{chr(98 + i)} [{', '.join([f'*{chr(97 + i)}'] * 9)}]" for i in range(8)
    ]
    nested = text.replace("  washers: 1\n", "  washers: " + "[" * 50_000 + "]" * 50_000 + "\n")
    long_list = "rig:\n  name: x\n  junk: [" + "1, " * 17_000_000 + "1]\n"  # about 50 MB
    return [
        refused("washers_nan", washers(".nan"), "washers", "finite"),
        refused("washers_inf", washers(".inf"), "washers", "finite"),
        refused("washers_400_digits", washers("9" * 400), "400 characters"),
        refused(
            "duplicate_key_block",
            text.replace("  washers: 1\n", "  washers: 1\n  washers: 5\n"),
            "duplicate key 'washers'",
            "lines 5 and 6",
        ),
        refused(
            "duplicate_key_quoted",
            text.replace("  washers: 1\n", '  washers: 1\n  "washers": 5\n'),
            "duplicate key 'washers'",
        ),
        refused(
            "duplicate_key_flow",
            text.replace("{count: 2,", "{count: 2, count: 4,"),
            "duplicate key 'count'",
        ),
        refused("invalid_utf8", text.encode().replace(b"name: ", b"name: \xff\xfe", 1), "UTF-8"),
        refused("binary", bytes(range(256)) * 8, "binary"),
        refused("nested_50000", nested, "nested deeper"),
        refused(
            "alias_bomb_in_number",
            text.replace("  washers: 1\n", "  washers: *i\n") + "\n".join(bomb) + "\n",
            "alias",
        ),
        refused(
            "alias_bomb_in_tolerance",
            text + "  tolerances: {caliper.stiffness: *i}\n" + "\n".join(bomb) + "\n",
            "alias",
        ),
        refused("fifty_megabytes", long_list, "larger than the limit"),
        refused("merge_key", text.replace("  washers: 1\n", "  <<: {washers: 2}\n"), "merge"),
    ]


def _write_wrong_format(folder: Path, storage: StoragePlugin) -> Path:
    """A bag like rosbag2's ``wrong_rmw_test``: two topics serialised as ``wrong_format``."""
    path = folder / f"wrong_rmw_test_{storage.name.lower()}"
    if path.exists():
        return path
    with Writer(path, version=8, storage_plugin=storage) as writer:
        for topic, count in (("/array_topic", 4), ("/test_topic", 3)):
            conn = writer.add_connection(
                topic,
                "std_msgs/msg/String",
                typestore=get_typestore(Stores.ROS2_KILTED),
                serialization_format="wrong_format",
            )
            for i in range(count):
                writer.write(conn, 1_000 + i, b"\x00\x01\x00\x00\x02\x00\x00\x00a\x00")
    return path


def _recording_cases(folder: Path, good_bag: Path, full: damage.Messages) -> list[Case]:
    good = damage.good_messages()
    rig = damage.GOOD_RIG
    cases: list[Case] = []

    def bag(name: str, messages: damage.Messages) -> Path:
        path = folder / name
        if not path.exists():
            messages.write(path)
        return path

    def refused(name: str, messages: damage.Messages, *fragments: str) -> None:
        cases.append(Case(name, bag(name, messages), rig, "refused", fragments))

    # the rate: 100 Hz refused; 250 Hz worked at its own rate (answer close to 1 kHz's)
    def decimated(step: int) -> damage.Messages:
        return damage.Messages(
            {s: (a[::step], b[::step], c[::step]) for s, (a, b, c) in good.topics.items()}
        )

    refused("rate_100_hz", decimated(10), "100 Hz", "below the minimum")
    cases.append(
        Case(
            "rate_250_hz",
            bag("rate_250_hz", decimated(4)),
            rig,
            "answer",
            commands=("compare", "characterize"),
            check=_close_to_good,
        )
    )
    refused(
        "p_b_ten_1e30",
        damage.set_values(good, BORE_PRESSURE, 3000, 10, 1e30),
        "/brake/bore/pressure",
        "physical bounds",
        "s into the topic",
    )
    refused(
        "p_i_ten_1e30",
        damage.set_values(good, MASTER_CYLINDER_PRESSURE, 3000, 10, 1e30),
        "/brake/master_cylinder/pressure",
        "physical bounds",
    )
    refused(
        "p_b_glitch_in_bounds",
        damage.set_values(good, BORE_PRESSURE, 3000, 5, 4.9e7),
        "/brake/bore/pressure",
        "faster than physically possible",
    )
    refused(
        "F_k_constant_in_bounds",
        damage.set_values(good, BLOCK_FORCE, 0, 10**6, 9e5),
        "F_k does not vary",
    )
    refused(
        "F_k_1e30_throughout",
        damage.set_values(good, BLOCK_FORCE, 0, 10**6, 1e30),
        "/brake/block/force",
        "physical bounds",
    )
    _gap_cases(refused, good, full)
    cases.append(
        Case(
            "two_removed_samples",
            bag("two_removed_samples", damage.drop(good, BLOCK_FORCE, 3000, 2)),
            rig,
            "answer",
            commands=("compare", "characterize"),
            check=_close_to_good,
        )
    )
    cases.extend(_door_cases(folder, good, rig))
    return cases


def _gap_cases(refused: Callable[..., None], good: damage.Messages, full: damage.Messages) -> None:
    """Holes and removed samples, in every topic or in one: refused as gaps."""
    hole = full
    for spec in list(full.topics):
        hole = damage.shift_stamps(hole, spec, 9000, 10_000_000_000)
    refused("hole_10_s", hole, "gap of 10", "not bridged")
    removed = full
    for spec in list(full.topics):
        removed = damage.drop(removed, spec, 4000, 10_000)
    refused("removed_10_s", removed, "gap of 10", "not bridged")
    refused(
        "hole_10_s_in_p_b_only",
        damage.shift_stamps(full, BORE_PRESSURE, 9000, 10_000_000_000),
        "/brake/bore/pressure",
        "gap",
    )
    refused(
        "removed_samples_p_i",
        damage.drop(good, MASTER_CYLINDER_PRESSURE, 3000, 50),
        "/brake/master_cylinder/pressure",
        "gap",
    )


def _door_cases(folder: Path, good: damage.Messages, rig: Path) -> list[Case]:
    """Doors before any library: FIFOs, an unreadable folder, unsupported serialisation."""
    cases: list[Case] = []
    fifo = folder / "fifo.mcap"
    if not fifo.exists():
        os.mkfifo(fifo)
    cases.append(Case("fifo_recording", fifo, rig, "refused", ("FIFO",)))
    fifo_bag = folder / "fifo_in_bag"
    if not fifo_bag.exists():
        good.write(fifo_bag)
        storage = damage.storage_file(fifo_bag)
        storage.unlink()
        os.mkfifo(storage)
    cases.append(Case("fifo_in_bag_folder", fifo_bag, rig, "refused", ("FIFO",)))
    locked = folder / "unreadable_folder"
    if not locked.exists():
        good.write(locked)
    locked.chmod(0)
    cases.append(Case("unreadable_folder", locked, rig, "either"))
    for storage in (StoragePlugin.MCAP, StoragePlugin.SQLITE3):
        path = _write_wrong_format(folder, storage)
        cases.append(
            Case(path.name, path, rig, "refused", ("wrong_format", "/array_topic", "/test_topic"))
        )
    return cases


def _close_to_good(_stdout: str, answer: Path) -> str | None:
    from test.hostile.fuzzing import baseline

    document = damage.read_json(answer)
    if not isinstance(document, dict) or "metrics" not in document:
        return None  # characterize: finite is checked by the caller
    return damage.close_to(document["metrics"], baseline()["metrics"])


def _output_cases(folder: Path, good_bag: Path) -> list[Case]:
    rig = damage.GOOD_RIG
    outside = folder / "outside_target.txt"
    outside.write_text("must stay as it is\n")
    link_folder = folder / "linked_out"
    link_folder.mkdir(exist_ok=True)
    link = link_folder / "answer.json"
    if not link.is_symlink():
        link.symlink_to(outside)
    diagnosis = folder / "diagnosis_with_link"
    diagnosis.mkdir(exist_ok=True)
    if not (diagnosis / "report.html").is_symlink():
        (diagnosis / "report.html").symlink_to(outside)
    a_file = folder / "a_file"
    a_file.write_text("x")
    return [
        Case(
            "json_in_proc",
            good_bag,
            rig,
            "refused",
            ("cannot write",),
            commands=("compare", "characterize"),
            json=Path("/proc/brake_hil.json"),
        ),
        Case(
            "json_is_folder",
            good_bag,
            rig,
            "refused",
            ("is a folder",),
            commands=("compare", "characterize"),
            json=folder,
        ),
        Case(
            "json_under_a_file",
            good_bag,
            rig,
            "refused",
            ("a_file",),
            commands=("compare", "characterize"),
            json=a_file / "x.json",
        ),
        Case(
            "json_link_out_of_folder",
            good_bag,
            rig,
            "refused",
            ("symbolic link",),
            commands=("compare", "characterize"),
            json=link,
        ),
        Case(
            "out_in_proc",
            good_bag,
            rig,
            "refused",
            ("cannot write",),
            commands=("diagnose",),
            out=Path("/proc/brake_hil"),
        ),
        Case(
            "out_is_a_file",
            good_bag,
            rig,
            "refused",
            ("not a folder",),
            commands=("diagnose",),
            out=a_file,
        ),
        Case(
            "out_with_link_out_of_folder",
            good_bag,
            rig,
            "refused",
            ("symbolic link",),
            commands=("diagnose",),
            out=diagnosis,
        ),
    ]


def _tolerance_zero(folder: Path, good_bag: Path) -> Case:
    text = damage.GOOD_RIG.read_text(encoding="utf-8")
    rig = _rig_variant(
        folder,
        "tolerance_zero",
        text + "  tolerances: {caliper.stiffness: 0, needle_valve.resistance: 0.0}\n",
    )

    def held_fixed(_stdout: str, answer: Path) -> str | None:
        if answer.is_dir():  # diagnose: the held values are not calibrated
            document = damage.read_json(answer / "diagnosis.json")
            assert isinstance(document, dict)
            fitted = set(document["calibration"]["multipliers"])
            if fitted & {"caliper_stiffness", "valve_resistance"}:
                return f"tolerance 0 not held fixed: calibrated {sorted(fitted)}"
            return None
        return _close_to_good(_stdout, answer)

    return Case("tolerance_zero", good_bag, rig, "answer", check=held_fixed)


def build(folder: Path) -> list[Case]:
    """Write the corpus into ``folder`` (made if missing) and return its cases."""
    folder.mkdir(parents=True, exist_ok=True)
    good_bag = folder / "good"
    if not good_bag.exists():
        damage.good_messages().write(good_bag)
    full = damage.full_messages()
    return [
        *_recording_cases(folder, good_bag, full),
        *_rig_cases(folder, good_bag),
        *_output_cases(folder, good_bag),
        _tolerance_zero(folder, good_bag),
    ]


if __name__ == "__main__":
    for case in build(Path(sys.argv[1] if len(sys.argv) > 1 else "hostile_corpus")):
        print(f"{case.name:32s} {case.expect:8s} {case.recording} --rig {case.rig.name}")
