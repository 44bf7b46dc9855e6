"""Benchmarks of the physics core: what accuracy costs, how the peers compare, how fast it runs.

Run them with ``microg bench accuracy|peers|throughput`` (see ``microg bench --help``). They are not
part of the test run; ``tests/test_bench_smoke.py`` only checks that ``--quick`` still works.

- ``scenarios``: the benchmark scenes as plain data and scripted hand paths, shared by every engine,
  with their independent answers (Newton's impact law, conservation, the undisturbed trajectory,
  ``scipy.integrate.solve_ivp`` for the tumble).
- ``ours``: the scenarios run on ``microg.sim``; ``peers``: the same on MuJoCo and PyBullet.
- ``accuracy``, ``throughput``: the sweeps and what they write (CSV and PNG).
"""
