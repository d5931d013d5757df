"""The robustness test of Sec. 4.3 (Table 4, Figs. 6-7): 0.288 kg at the link-2 tip,
the controllers keep the nominal model (Table 1).

Run it directly::

    python -m posfb.analysis.paper.payload_experiment [--out results/payload] [--duration 20]
    python analysis/paper/payload_experiment.py

Same options and outputs as ``analysis/paper/nominal_experiment.py``; both run the shipped
scenario files ``analysis/scenarios/paper_*.yaml``.
"""

from __future__ import annotations

from posfb.analysis.paper.nominal_experiment import main

if __name__ == "__main__":
    main("payload", __doc__.splitlines()[0])
