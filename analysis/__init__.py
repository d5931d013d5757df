"""posfb's studies and their front ends, in layers that import only downwards (the
contracts of ``[tool.importlinter]`` in ``pyproject.toml``, checked by
``tests/test_architecture.py``), top first:

* ``cli``: the ``posfb`` command line, one module per subcommand in ``cli.commands``;
* ``api``: the Python facade behind ``import posfb`` (``posfb.simulate``, ``posfb.tune``);
* the studies: ``realism`` ("How far from hardware?", made of Monte-Carlo studies) over
  ``paper`` (the reproduction of the paper's Sec. 4), ``montecarlo`` (robustness over
  sampled plants) and ``design`` (the design report, the stability map, robust tuning,
  a new arm's scenario), which do not import each other;
* ``uncertainty``: the study file and its distributions, sampling, the Assumption-1
  coverage, the sampled linear plants and the statistics of samples;
* ``common``: metrics, exports, figures, tables, output files, errors, progress bars,
  the shipped files, a scenario's feasibility and its linear loop effects.

The data folders ``scenarios/`` and ``studies/`` ship beside them (``common.shipped``).
"""
