"""Files of vcavity: tables (read, write, schema), sweep files, checkpoints, pre-flight checks and text summaries; h5py, never Numba."""
