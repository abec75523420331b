"""Vehicle plants: the paper's 2-DOF design model and a two-track validation model.

Both plants share one interface (`cosim.vehicle.plant.Plant`): a state whose first
six entries are the CG pose and body velocities (x, y, heading, vx, vy, yaw rate),
`step(h, delta, fx_cmd)` that integrates one substep with held inputs (fixed-step
RK4), and `outputs()` with accelerations and wheel forces at the current state.
"""
