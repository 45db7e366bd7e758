from setuptools import find_packages, setup

PACKAGE = "drill_nmpc"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    entry_points={"console_scripts": [   # ros2 run drill_nmpc <node module> (drill_ros.graph)
        "automated_mpd_node = drill_nmpc.automated_mpd_node:main",
        "baseline_node = drill_nmpc.baseline_node:main",
        "nmpc_node = drill_nmpc.nmpc_node:main",
        "sequencer_node = drill_nmpc.sequencer_node:main",
    ]},
    zip_safe=True,
    description="CasADi nonlinear MPC supervisor and its node.",
    license="Apache-2.0",
)
