"""Tripping a section stand by stand (docs/model.md, "Tripping a section"): the trip's
programme, the volumes a stand moves, the string on the slips or the elevator, the trip
tank and the trip sheet, the phases of each stand. Plain Python, no ROS.
"""
