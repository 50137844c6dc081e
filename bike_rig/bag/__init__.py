"""Bags of the rig.

Recording raw CDR into rosbag2/MCAP, reading with no ROS runtime, summaries, recovery after a
crash, and offline replay through the science core.

Modules: :mod:`.typestore` (rosbags types from our .msg files), :mod:`.writer`,
:mod:`.reader`, :mod:`.info`, :mod:`.recover`, :mod:`.replay` (offline, no rclpy),
:mod:`.republish` (into a live graph, rclpy), :mod:`.errors`.
"""
