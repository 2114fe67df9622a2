"""What the prosthesis does with the force estimate: controllers and loop analysis."""
