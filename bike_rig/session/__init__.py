"""The operator's session, without ROS: the plan, the readings as typed, the live state, the commands."""
