"""A recorded run's figures, plain Python over its MCAP (no rclpy): the run report
(summary.json, plots), the well-control report and the drilling report."""
