"""brake_hil: ament_python package, also pip-installable into a plain venv."""

from glob import glob

from setuptools import find_packages, setup

package_name = "brake_hil"

ROS_WHEELS = [  # PyPI wheels of ROS 2 Kilted, for users without a ROS install
    "ros-kilted-rclpy",
    "ros-kilted-rmw-fastrtps-cpp",
    "ros-kilted-std-msgs",
    "ros-kilted-sensor-msgs",
    "ros-kilted-geometry-msgs",
    "ros-kilted-diagnostic-msgs",
]

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*")),
    ],
    install_requires=[
        "setuptools",
        "numpy>=1.24",
        "scipy>=1.10",
        "PyYAML>=6",
        "mcap>=1.1",
        "mcap-ros2-support>=0.5",
        "rosbags>=0.10",
        "python-can>=4.3",
        "pyserial>=3.5",  # python-can's slcan interface (CAN over a serial link)
        "cantools>=39",
        "matplotlib>=3.7",
        "tqdm>=4.60",
        "distributed>=2024.1",  # Dask: work over many recordings (LocalCluster or a scheduler)
        "psycopg[binary]>=3.1",  # the results database on a PostgreSQL server (--db postgresql://)
    ],
    extras_require={
        "ros": ROS_WHEELS,
        "dev": [
            "pytest>=7",
            "hypothesis>=6",
            "ruff>=0.17,<0.18",  # its lint rules and format style move between minor versions
            "mypy>=1.8",
            "types-PyYAML",
            # a private PostgreSQL server for the results database's tests (its binaries bundled)
            "pgserver>=0.1.4",
            # the ROS 2 linters' standard tests (test/test_flake8.py, test/test_pep257.py):
            # the Kilted wheels carry no flake8/pydocstyle, which the distro's debs bring
            "ros-kilted-ament-flake8",
            "ros-kilted-ament-pep257",
            "flake8",
            "pydocstyle",
        ],
    },
    zip_safe=True,
    maintainer="brake_hil developers",
    maintainer_email="brake-hil@example.com",
    description="ROS 2 node suite for hardware-in-the-loop testing of hydraulic disk brakes",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "brake-hil = brake_hil.cli:main",
            "pressure_source = brake_hil.nodes.pressure_source:main",
            "caliper_model = brake_hil.nodes.caliper_model:main",
            "comparator = brake_hil.nodes.comparator:main",
            "recorder = brake_hil.nodes.recorder:main",
            "rig_emulator = brake_hil.nodes.rig_emulator:main",
        ],
    },
)
