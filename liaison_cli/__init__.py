"""liaison: Monte Carlo campaigns for autonomous cislunar orbit determination (LiAISON)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("liaison")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+source"
