from setuptools import find_packages, setup

PACKAGE = "drill_estimator"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    entry_points={"console_scripts": [   # ros2 run drill_estimator <node module> (drill_ros.graph)
        "estimator_node = drill_estimator.estimator_node:main",
    ]},
    zip_safe=True,
    description="Unscented Kalman filter for states and annular friction parameters, and its node.",
    license="Apache-2.0",
)
