"""Physical execution of a clip: a whole-body controller on the robot's `MultibodyPlant`.

A retargeted clip says where the joints go; this package says which
accelerations, contact forces and torques perform it. `whole_body_qp`
holds the one quadratic program solved at each control step (floating-base
dynamics, friction pyramids at the corners of the planted soles, torque
limits, weighted tracking tasks), `clip_plan` what the tasks track along a
clip (its centre-of-mass path from `pydrake.planning.ZmpPlanner`, its body
poses, its contact schedule), `footsteps` where a clip's swing foot may
land (beside where the capture point will be), `catch_step` where a robot
steps when its capture point leaves its feet, and the swing there. The Drake system that runs them in a diagram
is `hotu_drake.systems.whole_body.WholeBodyController`.
"""
