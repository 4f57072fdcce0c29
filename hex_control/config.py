"""Where the shipped configuration files are (config/*.yaml)."""

from __future__ import annotations

from pathlib import Path

import yaml


def config_file(name: str) -> Path:
    """Path of ``config/<name>``: the installed share directory, else the source tree."""
    try:
        from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

        try:
            installed = Path(get_package_share_directory("hex_control")) / "config" / name
            if installed.is_file():
                return installed
        except (PackageNotFoundError, OSError):  # OSError: no AMENT_PREFIX_PATH (venv)
            pass
    except ImportError:
        pass
    source = Path(__file__).resolve().parent.parent / "config" / name
    if not source.is_file():
        raise FileNotFoundError(f"no configuration file {name!r} (looked in the install and {source.parent})")
    return source


def config_path(source, folder: str = "") -> Path:
    """``source`` if it is a file, else the shipped ``config/<folder>/<source>``."""
    path = Path(source)
    return path if path.is_file() else config_file(f"{folder}/{source}" if folder else str(source))


def node_parameters(file_name: str, node: str) -> dict:
    """The ``ros__parameters`` of ``node`` (e.g. ``force_controller``, ``load_predictor/pass``)
    in a shipped parameter file, whose sections are written ``/**/<node>`` so that they
    apply in any namespace."""
    document = yaml.safe_load(config_file(file_name).read_text())
    key = f"/**/{node.strip('/')}"
    if key not in document:
        raise ValueError(f"{file_name} has no section {key}")
    return document[key]["ros__parameters"]
