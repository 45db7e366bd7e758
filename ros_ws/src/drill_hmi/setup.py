from setuptools import find_packages, setup

PACKAGE = "drill_hmi"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    entry_points={"console_scripts": [   # ros2 run drill_hmi <node module> (drill_ros.graph)
        "console = drill_hmi.console:main",
    ]},
    zip_safe=True,
    description="The operator's side: the web console, its state and form validation, and the operator command line; the gateways' write path goes through it.",
    license="Apache-2.0",
)
