from setuptools import find_packages, setup

PACKAGE = "drill_bringup"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + PACKAGE]),
        ("share/" + PACKAGE, ["package.xml"]),
        ("share/" + PACKAGE + "/launch", ["launch/rig.launch.py"]),   # drill_bringup.launch_file
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    description="The launcher of a run's graph: process layouts, split runs, the run directory, the launch file.",
    license="Apache-2.0",
)
