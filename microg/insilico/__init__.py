"""In-silico studies: a protocol's whole study played by simulated participants, and what is fitted
or planned from such studies (a population's calibration, ``microg power --simulated``).

    trials = simulate_trials(protocol, n_per_group=15, seed=3)            # the trials table
    trials = simulate_trials(protocol, 15, 3, population=read_population("pilot.toml"))

A simulated study plays every participant's tasks batched in compiled code (``engine``: the
participant, hand tracking's guard and filter, the physics, the task's rules), writes each task's
run to a temporary study as a session would, and keeps only its tables: the same trials table as the
logged sessions of the same seeds.

``microg.insilico.calibrate`` fits a population to a pilot's trials or to published numbers
(``targets``) by ABC-SMC on such studies (``summaries``: the numbers compared; ``sampler``: pyabc's
evaluations on Dask in a fixed order). It is imported on its own: it brings in pyabc.
"""

from .studies import simulate_trials, sized_protocol

__all__ = ["simulate_trials", "sized_protocol"]
