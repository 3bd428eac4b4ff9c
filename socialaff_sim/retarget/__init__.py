"""Robot descriptions, human-to-robot scaling and mink inverse kinematics."""
