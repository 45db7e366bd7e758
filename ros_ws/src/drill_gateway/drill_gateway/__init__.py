"""Gateways out of the rig: the Foxglove live view and the OPC-UA server (docs/gateways.md)."""
