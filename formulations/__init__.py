"""Contact formulations: problems built from a driveline state (DESIGN §2)."""
