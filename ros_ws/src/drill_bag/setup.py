from setuptools import find_packages, setup

PACKAGE = "drill_bag"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    entry_points={"console_scripts": [   # ros2 run drill_bag <node module> (drill_ros.graph)
        "recorder = drill_bag.recorder:main",
    ]},
    zip_safe=True,
    description="MCAP recordings: the recorder node, replay into a graph, export to Parquet and CSV, LAS and WITSML well logs.",
    license="Apache-2.0",
)
