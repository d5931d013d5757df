"""Robust tuning (``posfb tune``, ``posfb.tune``): the design plants (``plants``), the
problem (``problem``: decision variables, objective, constraints), the search
(``search``), the verification and its guarantee (``guarantee``), the whole run
(``tune``) and its report (``report``); settings in ``settings``. Nothing heavy is
imported here: ``posfb design --map`` reads ``settings`` at start-up."""
