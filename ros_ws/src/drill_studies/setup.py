from setuptools import find_packages, setup

PACKAGE = "drill_studies"

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
    description="Studies over many runs: the runner of many graphs, compare, sweeps, the fault matrix, benches, the loop bench, ladders.",
    license="Apache-2.0",
)
