"""Thin rclpy helpers shared by the nodes: topic names, QoS, stamps, status, lockstep inbox."""
