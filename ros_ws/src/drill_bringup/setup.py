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
    description="Launcher, split runs, the rig CLI, comparisons, sweeps and the in-process benches.",
    license="Apache-2.0",
)
