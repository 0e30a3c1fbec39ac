"""The jitted walk: light paths traced through sampled V-cavities, binned on the sensor per bounce order (trace, paper, groove)."""
