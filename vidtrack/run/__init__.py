"""A run: the stages from footage to fit.json, their cache, the worker process, the output files."""
