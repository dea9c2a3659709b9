"""``metadata.yaml`` of a rosbag2 MCAP directory: written, and recovered from the files.

What ``ros2 bag record -s mcap`` writes (rosbag2 metadata version 9, Kilted);
:func:`recover_metadata` rewrites it from the ``.mcap`` files, as ``ros2 bag reindex`` does
(ROS-free).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
import re
from typing import Any, Final

from rosbags.interfaces import Qos
from rosbags.rosbag2 import Reader
from rosbags.rosbag2.metadata import dump_qos_v9, parse_qos
import yaml

from brake_hil.io.mcap_files import FileInfo, TopicInfo

__all__ = [
    "METADATA_VERSION",
    "bag_metadata",
    "dump_metadata",
    "qos_text",
    "recover_metadata",
    "replace_text",
]

METADATA_VERSION: Final = 9
"""rosbag2 metadata version written (Kilted)."""

try:  # libyaml when present: metadata.yaml is rewritten at every chunk
    _Dumper: Any = yaml.CSafeDumper
except AttributeError:  # pragma: no cover - PyYAML without libyaml
    _Dumper = yaml.SafeDumper


def qos_text(profiles: Sequence[Qos]) -> str:
    """``offered_qos_profiles`` of an MCAP channel: the v9 list as YAML text."""
    return str(yaml.dump(dump_qos_v9(list(profiles)), Dumper=_Dumper, sort_keys=False)).strip()


def bag_metadata(
    files: Sequence[FileInfo],
    topics: Sequence[TopicInfo],
    counts: Mapping[int, int],
    custom_data: Mapping[str, str],
) -> dict[str, Any]:
    """The ``rosbag2_bagfile_information`` mapping of ``metadata.yaml``."""
    spans = [(f.start_ns, f.end_ns) for f in files if f.message_count]
    start = min((s for s, _ in spans), default=0)
    end = max((e for _, e in spans), default=0)
    return {
        "version": METADATA_VERSION,
        "storage_identifier": "mcap",
        "duration": {"nanoseconds": end - start},
        "starting_time": {"nanoseconds_since_epoch": start},
        "message_count": sum(f.message_count for f in files),
        "topics_with_message_count": [
            {
                "topic_metadata": {
                    "name": topic.name,
                    "type": topic.msgtype,
                    "serialization_format": topic.serialization_format,
                    "offered_qos_profiles": dump_qos_v9(list(topic.offered_qos_profiles)),
                    "type_description_hash": topic.type_hash,
                },
                "message_count": counts.get(handle, 0),
            }
            for handle, topic in enumerate(topics)
        ],
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [f.path.name for f in files],
        "files": [
            {
                "path": f.path.name,
                "starting_time": {"nanoseconds_since_epoch": f.start_ns},
                "duration": {"nanoseconds": f.end_ns - f.start_ns},
                "message_count": f.message_count,
            }
            for f in files
        ],
        "custom_data": dict(custom_data) or None,
        "ros_distro": "kilted",
    }


def dump_metadata(metadata: Mapping[str, Any]) -> str:
    """``metadata`` as the YAML text of ``metadata.yaml``."""
    return str(yaml.dump(metadata, Dumper=_Dumper, default_flow_style=False, sort_keys=False))


def replace_text(path: Path, text: str) -> Path:
    """Write ``text`` beside ``path`` (to be renamed over it); returns the temporary file."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf8")
    return tmp


_FILE_INDEX = re.compile(r"_(\d+)\.mcap$")


def recover_metadata(path: Path | str) -> Path:
    """Rewrite ``metadata.yaml`` of a rosbag2 MCAP directory from its ``.mcap`` files.

    For a recording whose writer was killed: counts, spans and the file list are taken from
    what the files hold (every file the recorder leaves is a valid MCAP, see the module
    doc). Topic QoS and type hashes come from the files' channels.

    Returns:
        The path of the new ``metadata.yaml``.

    Raises:
        FileNotFoundError: no ``.mcap`` file in ``path``.
        rosbags.rosbag2.ReaderError: a file cannot be read.
    """
    path = Path(path)

    def order(p: Path) -> tuple[int, str]:
        match = _FILE_INDEX.search(p.name)
        return (int(match.group(1)) if match else -1, p.name)

    mcaps = sorted(path.glob("*.mcap"), key=order)
    if not mcaps:
        raise FileNotFoundError(f"{path}: no .mcap files to recover")
    topics: dict[str, TopicInfo] = {}
    counts: dict[str, int] = {}
    files: list[FileInfo] = []
    for mcap_path in mcaps:
        with Reader(mcap_path) as reader:
            for connection in reader.connections:
                qos = getattr(connection.ext, "offered_qos_profiles", [])
                topics.setdefault(
                    connection.topic,
                    TopicInfo(
                        connection.topic,
                        connection.msgtype,
                        connection.msgdef.data,
                        connection.digest,
                        tuple(parse_qos(qos) if isinstance(qos, str) else qos),
                        getattr(connection.ext, "serialization_format", "cdr"),
                    ),
                )
                counts[connection.topic] = counts.get(connection.topic, 0) + connection.msgcount
            count = reader.message_count
            start, end = (reader.start_time, reader.end_time - 1) if count else (0, 0)
            files.append(FileInfo(mcap_path, count, start, end, mcap_path.stat().st_size))
    ordered = list(topics.values())
    by_handle = {i: counts[t.name] for i, t in enumerate(ordered)}
    document = {"rosbag2_bagfile_information": bag_metadata(files, ordered, by_handle, {})}
    target = path / "metadata.yaml"
    replace_text(target, dump_metadata(document)).replace(target)
    return target
