"""The uncertain arm, for every study that samples plants: ``study`` (the study YAML, its
distributions with Drake's names, its checks), ``sampling`` (one plant per ``(study,
index)``: random streams or a QMC/Saltelli design), ``coverage`` (inside or outside the
Assumption-1 bounds), ``plants`` (i.i.d. draws reduced to the linear plant of the
sampled-data loop, for ``design``) and ``statistics`` (intervals, rankings, Sobol'
indices and the Saltelli design they come from)."""
