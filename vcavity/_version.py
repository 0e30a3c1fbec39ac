"""The installed package's version, in a module of its own so that nothing imports the package root."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("vcavity")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"
