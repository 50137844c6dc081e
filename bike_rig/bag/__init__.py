"""Bags of the rig.

Recording raw CDR into rosbag2/MCAP, reading with no ROS runtime, summaries, recovery after a
crash, and offline replay through the science core.

Modules: :mod:`.typestore` (rosbags types from our .msg files), :mod:`.writer`,
:mod:`.reader`, :mod:`.schemas` (each topic decoded with its definition in the bag),
:mod:`.foreign` (another tool's MCAP refused), :mod:`.order` (the live results in publication
order), :mod:`.info`, :mod:`.recover`, :mod:`.replay` (offline, no rclpy), :mod:`.republish`
(into a live graph, rclpy), :mod:`.errors`.
"""
