"""The robot: URDF with loops, closure, kinematics, robots by name, URDF text editing."""
