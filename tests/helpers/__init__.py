"""The suite's shared test helpers, one module per job, imported as ``helpers.<module>``
(``tests/`` is on pytest's ``pythonpath``, so the imports work in every import mode):

- ``planar_arm``: a generated N-link planar URDF arm no shipped file describes;
- ``lumped_plant``: the lumped (Eq. 4) plant simulated without Drake's multibody plant;
- ``loop_checks``: structural and signal checks on a built closed loop (position only);
- ``montecarlo_helpers``: tiny studies, stores and results for the Monte-Carlo tests;
- ``plugin_helpers``: a controller plug-in written to a temporary file;
- ``figure_checks``: what a Matplotlib figure shows (legends, titles, colours);
- ``output_checks``: digests and read-only folders for the output-writing tests.
- ``paths``: the repository's root (``REPO``), for tests that read its files.

Fixtures shared across files live in ``tests/conftest.py``.
"""
