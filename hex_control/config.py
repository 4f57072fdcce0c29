"""Where the shipped configuration files are (config/*.yaml), and the cell configuration
built from them once: the one source of every physical value of the cell."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
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
    """``source`` if it is a file, else the shipped ``config/<folder>/<source>``. An absolute
    path names the user's own file: if it is missing, say so as given, instead of looking
    for it among the shipped files."""
    path = Path(source)
    if path.is_file():
        return path
    if path.is_absolute():
        raise FileNotFoundError(f"no file {str(source)!r}")
    return config_file(f"{folder}/{source}" if folder else str(source))


def node_parameters(file_name: str, node: str) -> dict:
    """The ``ros__parameters`` of ``node`` (e.g. ``force_controller``, ``load_predictor/pass``)
    in a shipped parameter file, whose sections are written ``/**/<node>`` so that they
    apply in any namespace."""
    document = yaml.safe_load(config_file(file_name).read_text())
    key = f"/**/{node.strip('/')}"
    if key not in document:
        raise ValueError(f"{file_name} has no section {key}")
    return document[key]["ros__parameters"]


#: the machine the shipped graph runs (the plant's and the kinematics node's default machine_file)
DEFAULT_MACHINE_FILE = "machines/nist_ingersoll.yaml"
#: the sections of config/cell.yaml and, from the machine file, its structural mode
CELL_SECTIONS = ("process", "disk", "table")
STRUCTURE_FIELDS = ("mode_frequency_hz", "mode_damping")


@dataclass(frozen=True, eq=False)
class CellConfiguration:
    """The cell's physical values, read once (issue 38 item 3): config/cell.yaml (``process``,
    ``disk``, ``table``) and the machine file's lightly damped structural mode
    (``structure``: ``mode_frequency_hz``, ``mode_damping``). Library dataclasses take their
    physical defaults from :func:`cell_configuration` (via :func:`cell_default`), the nodes
    their parameters' defaults; nothing else writes these numbers."""

    process: dict
    disk: dict
    table: dict
    structure: dict
    source: str = ""  # the files read, for messages

    def value(self, key: str) -> float:
        """One value by its dotted name, e.g. ``process.force_max_n`` or ``structure.mode_damping``."""
        section, _, name = key.partition(".")
        try:
            return float(getattr(self, section)[name])
        except (AttributeError, KeyError, TypeError, ValueError):
            raise ValueError(f"the cell ({self.source}) has no number {key!r}") from None

    @property
    def force_max_n(self) -> float:
        """F_max (N): the desired force's ceiling (seed 002 sec. 5.1)."""
        return self.value("process.force_max_n")

    @property
    def stiffness_n_per_mm(self) -> float:
        """K_x = K_theta / R^2 (N/mm, seed 002 eq. 7.1b): the disk mount's rotational stiffness at the rim."""
        return self.value("disk.spring_n_mm_rad") / self.value("process.disk_radius_mm") ** 2

    @property
    def overload_n(self) -> float:
        """The plant's overload trip (N): ``table.overload_ratio`` times F_max."""
        return self.value("table.overload_ratio") * self.force_max_n


def load_cell_configuration(cell="cell.yaml", machine=DEFAULT_MACHINE_FILE) -> CellConfiguration:
    """The cell configuration from a cell file and a machine file (paths or names under config/).
    ValueError for unknown sections or a machine file without its ``structure`` block."""
    cell_path, machine_path = config_path(cell), config_path(machine)
    data = yaml.safe_load(cell_path.read_text()) or {}
    unknown = set(data) - set(CELL_SECTIONS)
    if unknown:
        raise ValueError(f"unknown cell sections {sorted(unknown)} in {cell_path}")
    structure = (yaml.safe_load(machine_path.read_text()) or {}).get("structure") or {}
    if set(structure) != set(STRUCTURE_FIELDS):
        raise ValueError(f"{machine_path}: structure must give exactly {STRUCTURE_FIELDS}, got {sorted(structure)}")
    return CellConfiguration(*(dict(data.get(s) or {}) for s in CELL_SECTIONS), dict(structure),
                             f"{cell_path} + {machine_path}")


@lru_cache(maxsize=1)
def cell_configuration() -> CellConfiguration:
    """The shipped cell (config/cell.yaml and the default machine file), read once per process."""
    return load_cell_configuration()


def cell_default(key: str):
    """A ``default_factory`` for a dataclass field whose default is the cell's ``key``."""
    return lambda: cell_configuration().value(key)
