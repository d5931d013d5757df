"""The robustness test of Sec. 4.3 (Table 4, Figs. 6-7): 0.288 kg at the link-2 tip,
the controllers keep the nominal model (Table 1).

Run it directly::

    python -m posfb.diagrams.payload_experiment [--out results/payload] [--duration 20]
    python diagrams/payload_experiment.py

Same options and outputs as ``diagrams/nominal_experiment.py``.
"""

from __future__ import annotations

from posfb.diagrams.nominal_experiment import main

if __name__ == "__main__":
    main("payload", __doc__.splitlines()[0])
