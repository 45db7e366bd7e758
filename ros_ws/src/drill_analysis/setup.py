from setuptools import find_packages, setup

PACKAGE = "drill_analysis"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    description="A recorded run's figures without ROS: the report, the well-control and drilling reports.",
    license="Apache-2.0",
)
