"""Physics and control laws of posfb: no wiring, no I/O.

Where each part of the paper lives:

- ``lumped``      Sec. 4.1, the lumped two-link model in volts (Table 1).
- ``plant``       the URDF arm in a MultibodyPlant, motor stage and Coulomb friction.
- ``identify``    theta_1..theta_11 of Sec. 4.1 computed from a plant and Context.
- ``trajectory``  Sec. 4.2, the desired trajectory as a Drake system.
- ``validation``  shared checks that name the parameter, the value and what is allowed.
"""
