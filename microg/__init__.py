"""microg: run, log and analyse user studies of hand-object interaction in simulated microgravity."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("microg")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+source"
