"""Identification from encoder logs (issue 29): reading a log (``log``), identifying a
model from it and validating it on another (``identify``), and planning an exciting
trajectory for a scenario's arm (``plan``). The estimators are ``models.identification``'s."""
