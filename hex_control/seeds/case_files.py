"""Reading a seed's case file as hostile input: a missing file, broken YAML, a document
that is not a mapping, a missing section or key, or a value of the wrong kind each end in
one ``ValueError`` / ``FileNotFoundError`` line naming the file and what is wrong (hexctl
prints it and exits 2)."""

from __future__ import annotations

import math
from pathlib import Path

import yaml

from hex_control.config import config_path


def case_file(source, folder: str) -> Path:
    """``source`` if it names a file, a bare name under config/<folder>/, else
    FileNotFoundError naming the path as given (not glued to the folder)."""
    path = Path(source)
    if path.is_file():
        return path
    if path.is_absolute() or len(path.parts) > 1:
        raise FileNotFoundError(f"no case file {str(source)!r}")
    try:
        return config_path(str(source), folder)
    except FileNotFoundError:
        raise FileNotFoundError(f"no case file {str(source)!r} (neither a path nor in config/{folder}/)") from None


def load_case(source, folder: str, sections) -> tuple[Path, dict]:
    """(path, document) with every one of ``sections`` present; the document a mapping."""
    path = case_file(source, folder)
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        where = getattr(exc, "problem_mark", None)
        line = f" at line {where.line + 1}" if where is not None else ""
        raise ValueError(f"{path}: not valid YAML{line}") from None
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file") from None
    if not isinstance(data, dict):
        raise ValueError(f"{path}: must be a mapping of sections, got {type(data).__name__}")
    missing = [name for name in sections if name not in data]
    if missing:
        raise ValueError(f"{path}: missing section(s) {', '.join(missing)}")
    return path, data


def section(path: Path, data: dict, name: str, keys=()) -> dict:
    """data[name] as a mapping holding ``keys``."""
    value = data[name]
    if not isinstance(value, dict):
        raise ValueError(f"{path}: {name} must be a mapping, got {type(value).__name__}")
    missing = [key for key in keys if key not in value]
    if missing:
        raise ValueError(f"{path}: {name} is missing {', '.join(missing)}")
    return value


def number(path: Path, where: str, value, *, positive: bool = False, minimum: float | None = None) -> float:
    """A finite float (and > 0 with ``positive``, >= ``minimum``)."""
    if isinstance(value, bool):
        raise ValueError(f"{path}: {where} must be a number, got {value!r}")
    try:
        result = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{path}: {where} must be a number, got {value!r}") from None
    if not math.isfinite(result):
        raise ValueError(f"{path}: {where} must be finite, got {value!r}")
    if positive and not result > 0:
        raise ValueError(f"{path}: {where} must be > 0, got {value!r}")
    if minimum is not None and result < minimum:
        raise ValueError(f"{path}: {where} must be >= {minimum:g}, got {value!r}")
    return result


def integer(path: Path, where: str, value, *, minimum: int = 1) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or value != int(value) or value < minimum:
        raise ValueError(f"{path}: {where} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def numbers(path: Path, where: str, values, length: int, *, minimum: float | None = None) -> list[float]:
    if not isinstance(values, (list, tuple)) or len(values) != length:
        raise ValueError(f"{path}: {where} must be a list of {length} numbers, got {values!r}")
    return [number(path, f"{where}[{i}]", v, minimum=minimum) for i, v in enumerate(values)]
