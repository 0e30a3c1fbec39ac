"""The equal-solid-angle hemispherical sensor: its cells in plain NumPy (grid) and the jitted binning of exit directions (binning)."""
