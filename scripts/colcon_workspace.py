"""The colcon workspace of this checkout, build/colcon_ws (whatever the Makefile's BUILD): the
repository and the link to its interface package under src/ (docs/nodes.md), built with
colcon against the venv as underlay.

`make setup` builds hex_control_msgs here and installs that build into the venv as well
(``python scripts/colcon_workspace.py interfaces PREFIX``); test_colcon_build.py builds both
packages here with the same command, so its build of the interface package is up to date.
(colcon configures a CMake package again when its arguments differ from its last build's,
build/<package>/cmake_args.last: they are made here alone, from the venv's own paths.)
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
WORKSPACE = ROOT / "build/colcon_ws"
INTERFACES = "hex_control_msgs"
#: the interface package's C and Python parts only (HEX_PYTHON_ONLY: the C++ generators, which
#: nothing here loads, cost 33 of a full build's 75 CPU s), built as a unity build (46 -> 34 CPU
#: s; msg_defs/cmake/hex_interfaces.cmake); the venv's python by one name (sys.executable is
#: .../python3 when the caller was started so)
CMAKE_ARGS = ("-DBUILD_TESTING=OFF", "-DHEX_PYTHON_ONLY=ON", "-DCMAKE_UNITY_BUILD=ON",
              f"-DPython3_EXECUTABLE={Path(sys.prefix) / 'bin/python'}")


def workspace(path: Path = WORKSPACE, *, with_link: bool = True) -> Path:
    """A workspace holding the repository under src/ and, with ``with_link``, the link to its
    interface package beside it (colcon's crawl does not descend into a package)."""
    (path / "src").mkdir(parents=True, exist_ok=True)
    for name, target in (("hex_control", ROOT), (INTERFACES, Path("hex_control/msg_defs"))):
        link = path / "src" / name
        if link.is_symlink() and Path(os.readlink(link)) != target:
            link.unlink()
        if not link.is_symlink() and (name == "hex_control" or with_link):
            link.symlink_to(target)
    return path


def build(*packages: str, path: Path = WORKSPACE, capture: bool = True) -> subprocess.CompletedProcess:
    """``colcon build`` of ``packages`` (all it finds if none) with :data:`CMAKE_ARGS` in the
    workspace at ``path``, the venv (this interpreter's prefix: the ROS 2 wheels, tf2_msgs) its
    only underlay."""
    venv = Path(sys.prefix)
    env = dict(os.environ, AMENT_PREFIX_PATH=str(venv), CMAKE_PREFIX_PATH=str(venv))
    env.pop("COLCON_PREFIX_PATH", None)
    # colcon's make gets -j<cores> -l<cores> unless MAKEFLAGS names -j or -l (under `make` it
    # is set, empty or a jobserver's): beside the suite's other workers the load stays above
    # the core count, so -l built the interface package one file at a time (222 s at load 10);
    # a job per core, whatever the load
    env["MAKEFLAGS"] = f"-j{os.cpu_count() or 2}"
    selection = ("--packages-select", *packages) if packages else ()
    return subprocess.run([str(venv / "bin/colcon"), "--log-base", str(path / "log"), "build", *selection,
                           "--cmake-args", *CMAKE_ARGS], cwd=path, env=env, capture_output=capture, text=True,
                          timeout=900)


def install_interfaces(prefix: Path, path: Path = WORKSPACE) -> None:
    """Build the interface package in the workspace and install that build into ``prefix``
    as well (nothing in it depends on the install prefix given when it was configured: no
    RUNPATH, relative CMake config; only its unused share/<pkg>/local_setup.sh names the
    workspace's install as its default prefix)."""
    if build(INTERFACES, path=workspace(path), capture=False).returncode != 0:
        sys.exit(f"colcon build of {INTERFACES} failed (its log: {path / 'log/latest_build'})")
    subprocess.run(["cmake", "--install", str(path / "build" / INTERFACES), "--prefix", str(prefix)], check=True)


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] != "interfaces":
        sys.exit("usage: python scripts/colcon_workspace.py interfaces PREFIX")
    install_interfaces(Path(sys.argv[2]).resolve())
