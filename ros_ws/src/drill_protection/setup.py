from setuptools import find_packages, setup

PACKAGE = "drill_protection"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    entry_points={"console_scripts": [   # ros2 run drill_protection <node module> (drill_ros.graph)
        "protection_node = drill_protection.protection_node:main",
    ]},
    zip_safe=True,
    description="Process protection between the advisors and the machines.",
    license="Apache-2.0",
)
