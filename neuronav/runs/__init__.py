"""Experiments: the scenario interface, trials, runs and sweeps over worker pools or a Dask cluster,
run folders, records, progress, figures and the command line. May import the whole core."""
