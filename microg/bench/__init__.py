"""Benchmarks of the physics core: what accuracy costs, how the peers compare, how fast it runs.

Run them with ``microg bench accuracy|peers|throughput|coldstart`` (see ``microg bench --help``). They
are not part of the test run; ``tests/sim/test_hard_bench_smoke.py`` only checks that ``--quick`` still
works. Every time is a ratio or rate measured in the same run; no test asserts a time.

- ``scenarios``: the benchmark scenes as plain data and scripted hand paths, shared by every engine,
  with their independent answers (Newton's impact law, conservation, the undisturbed trajectory,
  ``scipy.integrate.solve_ivp`` for the tumble).
- ``ours``: the scenarios run on ``microg.sim``; ``peers``: the same on MuJoCo and PyBullet.
- ``accuracy``, ``throughput``: the sweeps and what they write (CSV and PNG); ``throughput`` also
  times batched stepping (``step_batch``) beside MuJoCo's ``rollout`` of the same scene.
- ``coldstart``: a fresh process to its first physics frame with an empty compile cache.
"""
