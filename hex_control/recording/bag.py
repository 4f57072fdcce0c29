"""Recordings in rosbag2's MCAP layout, without rosbag2 (it is not on PyPI): a directory
with ``metadata.yaml`` and ``<name>_0.mcap``, which ``ros2 bag``, Foxglove and PlotJuggler
open. Messages are stored as their CDR bytes (the ``cdr`` message encoding) under schemas
of encoding ``ros2msg``: the type's .msg text followed by every type it uses, each after
a line of 80 '=' and ``MSG: pkg/Type`` (rosbag2_storage_mcap's message definition format).

No ROS here: the bytes come serialized (:mod:`hex_control.ros.tools.recorder` subscribes raw);
the .msg texts come from the installed interface packages' share directories.

Times are nanoseconds since the epoch (the time each message was received).
"""

from __future__ import annotations

import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from mcap.reader import make_reader
from mcap.well_known import MessageEncoding, SchemaEncoding
from mcap.writer import CompressionType, Writer

ROSBAG2_VERSION = 9
_SEPARATOR = "=" * 80
PRIMITIVES = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32", "uint32",
               "int64", "uint64", "string", "wstring"}


def interface_share(package: str) -> Path:
    """An interface package's share directory: from the ament index, else the venv's (the
    wheels install there; the index is only set up in a sourced ROS environment)."""
    from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

    try:
        return Path(get_package_share_directory(package))
    except (OSError, PackageNotFoundError):
        share = Path(sys.prefix) / "share" / package
        if not share.is_dir():
            raise ValueError(f"no interface package {package!r} installed") from None
        return share


def _interface_text(type_name: str) -> str:
    """The definition of ``pkg/msg/Type`` (or an action's or service's part, e.g.
    ``pkg/action/Name_Feedback``) as its file writes it."""
    package, kind, name = type_name.split("/")
    if kind == "msg":
        return (interface_share(package) / "msg" / f"{name}.msg").read_text()
    base, _, part = name.rpartition("_")
    parts = {"action": ("Goal", "Result", "Feedback"), "srv": ("Request", "Response")}[kind]
    if part not in parts:
        raise ValueError(f"{type_name}: not a part of an {kind} ({', '.join(parts)})")
    sections = re.split(r"^---\s*$", (interface_share(package) / kind / f"{base}.{kind}").read_text(), flags=re.M)
    return sections[parts.index(part)].strip("\n") + "\n"


def _used_types(text: str, package: str) -> list[str]:
    """The message types a definition's fields use, as ``pkg/msg/Type``."""
    used = []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        tokens = line.split()
        if len(tokens) > 1 and ("=" in tokens[1] or len(tokens) > 2 and tokens[2].startswith("=")):
            continue  # a constant
        base = re.split(r"[\[<]", tokens[0])[0]  # without array and string bounds
        if base in PRIMITIVES:
            continue
        if base == "Header":
            used.append("std_msgs/msg/Header")
        elif "/" in base:
            pkg, _, name = base.rpartition("/")
            used.append(f"{pkg.split('/')[0]}/msg/{name}")
        else:
            used.append(f"{package}/msg/{base}")
    return used


def message_definition(type_name: str) -> str:
    """The ``ros2msg`` schema text of ``type_name``: its definition, then every type it uses
    (depth first, each once)."""
    text = _interface_text(type_name)
    parts, seen = [text.rstrip("\n")], {type_name}
    pending = _used_types(text, type_name.split("/")[0])
    while pending:
        dependency = pending.pop(0)
        if dependency in seen:
            continue
        seen.add(dependency)
        dependency_text = _interface_text(dependency)
        package, _, name = dependency.split("/")
        parts.append(f"{_SEPARATOR}\nMSG: {package}/{name}\n{dependency_text.rstrip()}")
        pending = _used_types(dependency_text, package) + pending
    return "\n".join(parts) + "\n"


@dataclass
class _Topic:
    name: str
    type: str
    qos: list[dict]
    channel: int
    count: int = 0


@dataclass
class BagWriter:
    """Write ``directory/metadata.yaml`` and ``directory/<name>_0.mcap``; use as a context
    manager or call :meth:`close`."""

    directory: Path
    _topics: dict[str, _Topic] = field(default_factory=dict)

    def __post_init__(self):
        self.directory = Path(self.directory)
        if self.directory.exists() and any(self.directory.iterdir()):
            raise ValueError(f"{self.directory} exists and is not empty: a recording needs a directory of its own")
        self.directory.mkdir(parents=True, exist_ok=True)
        self.file_name = f"{self.directory.name}_0.mcap"
        self._stream = open(self.directory / self.file_name, "wb")
        self._writer = Writer(self._stream, compression=CompressionType.ZSTD)
        self._writer.start(profile="ros2", library="hex_control")
        self._schemas: dict[str, int] = {}
        self.first_ns = self.last_ns = None

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def add_topic(self, name: str, type_name: str, qos: list[dict] | None = None) -> None:
        """Declare a topic before its first message; ``qos``: the publishers' offered QoS as
        rosbag2 writes them (history, depth, reliability, durability ...)."""
        if name in self._topics:
            return
        if type_name not in self._schemas:
            self._schemas[type_name] = self._writer.register_schema(type_name, SchemaEncoding.ROS2,
                                                                    message_definition(type_name).encode())
        qos = qos or []
        channel = self._writer.register_channel(name, MessageEncoding.CDR, self._schemas[type_name],
                                                {"offered_qos_profiles": yaml.safe_dump(qos)})
        self._topics[name] = _Topic(name, type_name, qos, channel)

    def write(self, topic: str, data: bytes, time_ns: int) -> None:
        """One message's CDR bytes, received at ``time_ns``."""
        entry = self._topics[topic]
        entry.count += 1
        self._writer.add_message(entry.channel, log_time=time_ns, data=bytes(data), publish_time=time_ns,
                                 sequence=entry.count)
        self.first_ns = time_ns if self.first_ns is None else min(self.first_ns, time_ns)
        self.last_ns = time_ns if self.last_ns is None else max(self.last_ns, time_ns)

    def close(self) -> None:
        if self._stream.closed:
            return
        self._writer.finish()
        self._stream.close()
        start, end = self.first_ns or 0, self.last_ns or 0
        total = sum(t.count for t in self._topics.values())
        span = {"starting_time": {"nanoseconds_since_epoch": start}, "duration": {"nanoseconds": end - start}}
        info = {"version": ROSBAG2_VERSION, "storage_identifier": "mcap", **span, "message_count": total,
                "topics_with_message_count": [
                    {"topic_metadata": {"name": t.name, "type": t.type, "serialization_format": "cdr",
                                        "offered_qos_profiles": t.qos, "type_description_hash": ""},
                     "message_count": t.count} for t in self._topics.values()],
                "compression_format": "", "compression_mode": "", "relative_file_paths": [self.file_name],
                "files": [{"path": self.file_name, **span, "message_count": total}],
                "custom_data": None, "ros_distro": "kilted"}
        (self.directory / "metadata.yaml").write_text(yaml.safe_dump({"rosbag2_bagfile_information": info},
                                                                     sort_keys=False))


def bag_info(directory) -> dict:
    """``metadata.yaml``'s information of a recording."""
    path = Path(directory) / "metadata.yaml"
    if not path.is_file():
        raise ValueError(f"{directory} is not a recording (no metadata.yaml)")
    return yaml.safe_load(path.read_text())["rosbag2_bagfile_information"]


def _size(n_bytes: int) -> str:
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n_bytes < 1024 or unit == "GiB":
            return f"{n_bytes:.1f} {unit}" if unit != "B" else f"{n_bytes} B"
        n_bytes /= 1024
    return ""


def _stamp(time_ns: int) -> str:
    """A time as ``ros2 bag info`` prints it: local date and time, then seconds since the epoch."""
    seconds, nanoseconds = divmod(time_ns, 1_000_000_000)
    return f"{time.strftime('%b %e %Y %H:%M:%S', time.localtime(seconds))}.{nanoseconds:09d} " \
           f"({seconds}.{nanoseconds:09d})"


def describe(directory) -> str:
    """``ros2 bag info``'s text: files, size, storage, duration, start, end, message count,
    and each topic with its type, count and serialization format."""
    info = bag_info(directory)
    size = sum(f.stat().st_size for f in Path(directory).iterdir() if f.is_file())
    start = info["starting_time"]["nanoseconds_since_epoch"]
    duration = info["duration"]["nanoseconds"]
    entries = info["topics_with_message_count"]
    lines = [f"Files:             {', '.join(info['relative_file_paths'])}",
             f"Bag size:          {_size(size)}",
             f"Storage id:        {info['storage_identifier']}",
             f"ROS Distro:        {info.get('ros_distro', '')}",
             f"Duration:          {duration / 1e9:.9f}s",
             f"Start:             {_stamp(start)}",
             f"End:               {_stamp(start + duration)}",
             f"Messages:          {info['message_count']}"]
    for number, entry in enumerate(entries):
        meta = entry["topic_metadata"]
        lines.append(("Topic information: " if number == 0 else " " * 19)
                     + f"Topic: {meta['name']} | Type: {meta['type']} | Count: {entry['message_count']} | "
                     f"Serialization Format: {meta['serialization_format']}")
    return "\n".join(lines)


def read_messages(directory, topics=None):
    """(topic, type, CDR bytes, time_ns) of a recording in time order, of ``topics`` or all."""
    info = bag_info(directory)
    for relative in info["relative_file_paths"]:
        with open(Path(directory) / relative, "rb") as stream:
            for schema, channel, message in make_reader(stream).iter_messages(topics=topics, log_time_order=True):
                yield channel.topic, schema.name, message.data, message.log_time
