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
    description="On-bottom drill-string dynamics for drilling mode, without ROS: lumped axial and "
                "torsional string, bit-rock law with the blade delay, time integration and the "
                "decoupled axial stability analysis.",
    license="Apache-2.0",
)
