"""Parameter sweeps: the sweep file's spec and grid, resumable runs over its points, and a sweep's albedo with its error."""
