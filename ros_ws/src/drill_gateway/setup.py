from setuptools import find_packages, setup

PACKAGE = "drill_gateway"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    entry_points={"console_scripts": [   # ros2 run drill_gateway <node module> (drill_ros.graph)
        "foxglove_node = drill_gateway.foxglove_node:main",
        "opcua_node = drill_gateway.opcua_node:main",
        "wits0_node = drill_gateway.wits0_node:main",
    ]},
    zip_safe=True,
    description="Gateways out of the rig: the Foxglove live view, the OPC-UA server and the WITS0 stream.",
    license="Apache-2.0",
)
