"""The building blocks every study and front end uses: ``metrics`` (a run's RMS errors and
verdict), ``export`` (time series and tables to files), ``plots`` (run and report
figures), ``tables`` (the paper's tables side by side), ``outputs`` (atomic files, staged
folders), ``errors`` (exit codes and the errors that carry them), ``progress`` (progress
bars), ``shipped`` (the shipped scenarios and studies by name), ``cases`` (the paper's two
cases), ``feasibility`` (a trajectory's warnings before a run) and ``loop_effects`` (a
scenario's linear effects, as the sampled-loop analyses take them)."""
