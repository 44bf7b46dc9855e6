"""Hypothesis runs the same examples on every run by default, so CI is repeatable (and a local run
is CI's: no examples replayed from an earlier run's database); set HYPOTHESIS_PROFILE=explore to
search with fresh random examples on each run."""

import os

from hypothesis import settings

settings.register_profile("repeatable", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "repeatable"))
