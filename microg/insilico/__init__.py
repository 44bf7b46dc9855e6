"""In-silico studies: a protocol's whole study played by simulated participants, and what is fitted
or planned from such studies (a population's calibration, ``microg power --simulated``).

    trials = simulate_trials(protocol, n_per_group=15, seed=3)            # the trials table
    trials = simulate_trials(protocol, 15, 3, population=read_population("pilot.toml"))

A simulated study runs the real sessions (the session runner, hand tracking, the physics, the task's
rules) with simulated participants on simulation time, and keeps only its tables: nothing is logged
to disk but a temporary study.

``microg.insilico.calibrate`` fits a population to a pilot's trials or to published numbers
(``targets``) by ABC-SMC on such studies (``summaries``: the numbers compared; ``sampler``: pyabc's
evaluations on Dask in a fixed order). It is imported on its own: it brings in pyabc.
"""

from .studies import simulate_trials, sized_protocol

__all__ = ["simulate_trials", "sized_protocol"]
