"""The model-error study (issue 29, item 5): how accurately ``posfb identify`` finds the
paper's theta from a planned excitation at a given encoder resolution (part a), the
paper's Table 3-4 experiments on arms drawn from that identification's uncertainty
(part b), and the size of model error at which each controller's joint-1 error reaches
the hardware's (part c). Labelled: no default changes; ``posfb model-error`` runs it.

``spec`` reads the study file, ``accuracy`` runs the identifications, ``experiments``
makes the Monte-Carlo studies of parts b and c (realism studies, ``analysis.realism``),
``voltage_error`` measures a model error's size, ``report`` writes the report, ``run``
runs it all.
"""
