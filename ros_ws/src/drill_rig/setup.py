from setuptools import find_packages, setup

PACKAGE = "drill_rig"

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
    description="The rig's front: the rig command line and the Python API.",
    license="Apache-2.0",
)
