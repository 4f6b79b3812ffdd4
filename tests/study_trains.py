"""Small train data shared by the study tests (one- and two-car trains of a 10-DOF car)."""

TRAINS_TOML = """
[[vehicle]]
id = "minicar"
bogie_spacing = 6.0
wheelbase = 2.0
[vehicle.whole]
body_mass = 30000.0
body_pitch_inertia = 1.0e6
bogie_mass = 2000.0
bogie_pitch_inertia = 1500.0
wheelset_mass = 1500.0
primary_stiffness = 2.0e6
primary_damping = 3.0e4
secondary_stiffness = 6.0e5
secondary_damping = 2.0e4

[[train]]
id = "one-car"
vehicles = ["minicar"]

[[train]]
id = "two-cars"
vehicles = ["minicar", "minicar"]
vehicle_offsets = [0.0, 12.0]
junctions = ["coupled"]
"""
