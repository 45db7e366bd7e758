from setuptools import find_packages, setup

PACKAGE = "drill_string"

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
    description="Drilling mode: on-bottom drill-string dynamics (plain-Python core) and the "
                "drilling graph's nodes (drill_string.ros).",
    license="Apache-2.0",
)
