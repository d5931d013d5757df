"""Identification of an arm's model from encoder logs (issue 29).

- ``theta_regressor``: Eq. 4 of the two-link arm written linearly in theta_1..theta_11;
- ``estimate``: filtering, derivatives and weighted least squares with the covariance;
- ``theta``: theta of the paper's arm from a log, its warnings, the bounded model;
- ``serial_regressor``: any serial arm's regressor and its base parameters;
- ``serial``: a serial URDF arm from a log (base parameters, motor-constant ratios);
- ``consistent``: the physically consistent arm closest to an estimate, as a URDF;
- ``checks``: what an estimate says about itself (the warnings);
- ``excitation``: an exciting finite-Fourier trajectory (Swevers et al. 1997);
- ``validation``: a model checked on a second log (voltage and output error);
- ``model_file``: the file ``posfb identify --out`` writes and ``!Identified`` reads.

Reading logs, the command and the report are ``posfb.analysis.identification``'s.
"""
