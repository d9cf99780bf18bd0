"""Observers of the integrator: what happens inside an accepted step, located from the step's two
ends and its dense output (docs/model.md, "Events"). Each is called by solver.loop at one fixed
point, after a step is accepted: the tension records (tension), the contact intervals (contacts),
a free body's stop and separation (body); events located on true sub-steps (events)."""
