"""The drilling graph's nodes: thin rclpy shells over drill_string's plain core (the plant,
the drives, the driller's schedule)."""
