"""cardan-forces: driveline."""
