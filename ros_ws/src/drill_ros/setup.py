from setuptools import find_packages, setup

PACKAGE = "drill_ros"

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
    description="The rig's ROS runtime: the graph declared once (nodes, topics, QoS, process layouts), the node base, lockstep, the container and its local bus, stamps, status and event publishing.",
    license="Apache-2.0",
)
