"""ROS 2 nodes of bike_rig: thin adapters between messages and the science core."""
