"""Path-following control (paper Section 4): errors against the planned reference,
the MIMO triple-step law and its SISO baseline, the longitudinal law, the
allocation to four wheels, and the closed loop that runs them with a plant."""
