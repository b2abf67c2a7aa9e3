"""cardan-forces: solvers."""
