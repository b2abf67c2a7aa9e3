"""cardan-forces: experiments."""
