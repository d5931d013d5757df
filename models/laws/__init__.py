"""Controller update laws written once, as CasADi functions: the simulated controller
evaluates them (``law.Stepper``) and ``posfb codegen`` prints them as C
(``c_code``), so the code that runs on an arm is the controller that was simulated.

A law has the contract of ``models.controllers.base``: ``start(q_0, desired_0)`` gives
the memory before the first sample, ``step(memory, q_k, desired_k)`` the voltage before
saturation, the internals and the next memory.
"""
