"""The real Dask cluster of the power tests (a scheduler and two workers on 127.0.0.1)."""

from tests.power.conftest import dask_cluster  # noqa: F401
