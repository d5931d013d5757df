"""``posfb codegen``: a scenario's designed controller as C (``package``), compiled and
checked against a log (``check``)."""
