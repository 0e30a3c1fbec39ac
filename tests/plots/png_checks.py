"""A PNG written by a plot is a real picture: signature, size, and not a blank canvas."""

import numpy as np

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def assert_png(path):
    """Assert that ``path`` is a PNG of at least 300 x 300 pixels with visible content."""
    import matplotlib.image

    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE and len(data) > 10_000
    pixels = matplotlib.image.imread(path)
    assert pixels.shape[0] > 300 and pixels.shape[1] > 300
    assert float(np.std(pixels[..., :3])) > 0.05  # drawn, not a blank canvas
