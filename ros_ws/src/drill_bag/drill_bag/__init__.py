"""MCAP recordings of the rig: the recorder node, replay into a graph, export to CSV and Parquet."""
