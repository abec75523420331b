"""The lane-change planner (paper Sections 2-3)."""
