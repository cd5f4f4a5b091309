"""Kinematic retargeting: human -> UDH -> every robot, part by part."""
