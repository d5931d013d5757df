"""Controller design for a scenario: the report of ``posfb design`` and ``posfb scenario
check`` (``report``), the stability map (``stability_map``, ``posfb design --map``), a new
arm's scenario (``scenario_init``, ``posfb scenario init``) and robust tuning (``posfb
tune``, ``posfb.tune``): the problem (``problem``: decision variables, objective,
constraints), the search (``search``), the verification and its guarantee
(``guarantee``), the wall-clock budget (``budget``), the whole run (``tune``) and its
report (``tune_report``); settings in ``settings``; the design plants are
``analysis.uncertainty.plants``. Nothing heavy is imported here: ``posfb design --map``
reads ``settings`` at start-up."""
