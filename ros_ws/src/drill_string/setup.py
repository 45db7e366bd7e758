from setuptools import find_packages, setup

PACKAGE = "drill_string"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    entry_points={"console_scripts": [   # ros2 run drill_string <node module> (drill_ros.graph)
        "actuator_node = drill_string.ros.actuator_node:main",
        "driller_node = drill_string.ros.driller_node:main",
        "plant_node = drill_string.ros.plant_node:main",
    ]},
    zip_safe=True,
    description="Drilling mode: on-bottom drill-string dynamics (plain-Python core) and the "
                "drilling graph's nodes (drill_string.ros).",
    license="Apache-2.0",
)
