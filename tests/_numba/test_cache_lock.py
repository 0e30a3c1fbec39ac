"""Numba's cache index written by several processes at once (vcavity/_numba/cache_lock.py).

Two processes save different keys into one index as fast as they can, as two warm-ups or
two Dask workers compiling different specialisations of one function into one cache do.
Every key must then load its own data: without the lock, both processes pick the same
data-file number now and then, and a key loads the other process's data (or is lost).
Deterministic in what it asserts; whether the unlocked race shows depends on scheduling:
with the lock removed this test failed 3 of 3 runs here (32-148 of the 600 keys wrong), and
one such run by hand left 30 keys loading the other process's data and 198 lost.
"""

import os
import subprocess
import sys

from numba.core.caching import IndexDataCacheFile

SAVES = 300
CHILD = """
import sys
import vcavity._numba.jit  # installs the lock for vcavity's cache folder (NUMBA_CACHE_DIR here)
from numba.core.caching import IndexDataCacheFile
index = IndexDataCacheFile(cache_path=sys.argv[1], filename_base="probe", source_stamp="stamp")
who = sys.argv[2]
for i in range({saves}):
    index.save((who, i), (who, i, "data"))
""".format(saves=SAVES)


def test_concurrent_saves_of_different_keys_each_load_their_own_data(tmp_path):
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path))
    children = [subprocess.Popen([sys.executable, "-c", CHILD, str(tmp_path), who], env=env,
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                for who in ("a", "b")]
    for child in children:
        _, err = child.communicate(timeout=300)
        assert child.returncode == 0, err
    index = IndexDataCacheFile(cache_path=str(tmp_path), filename_base="probe", source_stamp="stamp")
    wrong = [(who, i) for who in ("a", "b") for i in range(SAVES) if index.load((who, i)) != (who, i, "data")]
    assert wrong == [], f"{len(wrong)} of {2 * SAVES} keys load other data or none, e.g. {wrong[:3]}"


def test_other_caches_are_left_to_numba(tmp_path):
    # an index outside vcavity's cache folder is saved as Numba does, without a lock file
    import vcavity._numba.jit  # noqa: F401  (installs the lock for vcavity's folder)

    index = IndexDataCacheFile(cache_path=str(tmp_path), filename_base="other", source_stamp="stamp")
    index.save(("k",), ("v",))
    assert index.load(("k",)) == ("v",)
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".lock")]
