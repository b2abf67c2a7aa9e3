"""cardan-forces: paper_repro."""
