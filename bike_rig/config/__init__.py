"""The rig's names and settings, without ROS: shipped configuration files, topic names, option specs."""
