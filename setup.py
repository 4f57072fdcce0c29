"""ament_python package hex_control (see package.xml)."""
from glob import glob

from setuptools import Extension, find_packages, setup

PACKAGE = "hex_control"

# One console script per node: `ros2 run hex_control <name>` in a full ROS 2 install
# (setup.cfg puts them in lib/hex_control), `hex-<name>` on the PATH of the venv.
NODES = {
    "load_predictor": "hex_control.ros.nodes.load_predictor:main",
    "synthetic_load": "hex_control.ros.nodes.synthetic_load:main",
    "kinematics": "hex_control.ros.nodes.kinematics:main",
    "sequence_planner": "hex_control.ros.nodes.sequence_planner:main",
    "input_shaper": "hex_control.ros.nodes.input_shaper:main",
    "force_controller": "hex_control.ros.nodes.force_controller:main",
    "plant": "hex_control.ros.nodes.plant:main",
    "pass_planner": "hex_control.ros.nodes.pass_planner:main",
    "robot_state": "hex_control.ros.nodes.robot_state:main",
}

# The pass simulation's contact kernel in C (grinding/_contact_c.c; contact.py runs the same
# algorithm in Python when it is not built). No fused multiply-add, and libm's sin, cos and tan
# as Python's math calls them: the Python kernel's roundings.
CONTACT_KERNEL = Extension(f"{PACKAGE}.grinding._contact_c", [f"{PACKAGE}/grinding/_contact_c.c"],
                           extra_compile_args=["-O2", "-ffp-contract=off", "-fno-builtin-sin", "-fno-builtin-cos",
                                               "-fno-builtin-tan"], optional=True)
# The plant's per-period forward kinematics in C (kinematics/_stewart_c.c; stewart.py runs the
# same Newton steps in numpy when it is not built)
FK_KERNEL = Extension(f"{PACKAGE}.kinematics._stewart_c", [f"{PACKAGE}/kinematics/_stewart_c.c"],
                      extra_compile_args=["-O2"], optional=True)

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*"]),
    ext_modules=[CONTACT_KERNEL, FK_KERNEL],
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob("config/*.yaml")),
        (f"share/{PACKAGE}/config/machines", glob("config/machines/*.yaml")),
        (f"share/{PACKAGE}/config/unit_commitment", glob("config/unit_commitment/*.yaml")),
        (f"share/{PACKAGE}/config/milling", glob("config/milling/*.yaml")),
        (f"share/{PACKAGE}/config/mobile_platform", glob("config/mobile_platform/*.yaml")),
        (f"share/{PACKAGE}/config/foxglove", glob("config/foxglove/*.json")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="hex_control developers",
    maintainer_email="hex-control@example.org",
    description="Hierarchical control of weld-bead grinding on a parallel-kinematic machine tool",
    license="Apache-2.0",
    tests_require=["pytest"],
    entry_points={
        "console_scripts": [f"{name} = {target}" for name, target in NODES.items()]
        + [f"hex-{name.replace('_', '-')} = {target}" for name, target in NODES.items()]
        + ["hexctl = hex_control.cli:main"],
    },
)
