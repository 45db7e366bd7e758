from setuptools import find_packages, setup

PACKAGE = "drill_plant"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    entry_points={"console_scripts": [   # ros2 run drill_plant <node module> (drill_ros.graph)
        "actuator_node = drill_plant.actuator_node:main",
        "plant_node = drill_plant.plant_node:main",
        "floor_node = drill_plant.floor_node:main",
    ]},
    zip_safe=True,
    description="Truth plant (stochastic wellbore hydraulics + hoisting) and actuator nodes.",
    license="Apache-2.0",
)
