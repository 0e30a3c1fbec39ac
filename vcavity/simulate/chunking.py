"""How many RNG blocks one walk call traces: fixed, or sized by time (the default).

A call is the pipeline's unit of everything that happens between blocks: a Ctrl-C or
SIGTERM is honoured, the progress bar moves, a checkpoint may be written. A fixed number
of blocks per call is a fixed amount of *paths*, whose cost ranges over four orders of
magnitude (a mirror at normal incidence against Smith's walk at GGX alpha = 1000, whose
paths bounce thousands of times: 0.66 s per block of 4096 paths on one core), and on a
GPU one launch needs hundreds of thousands of blocks before the device is full. So by
default a call is sized to take about :data:`TARGET_S` seconds from the throughput the
last calls measured: a few blocks for the slowest walks, millions of paths for the
fastest, as many threads as a GPU holds. The size of a call never changes a table (each
block owns its random stream and tallies are integers), so sizing by time keeps runs
reproducible.
"""

from __future__ import annotations

#: Seconds of work one call aims at on the CPU: an interrupt is answered, and the progress
#: bar moves, within about this (well inside the 2 s the hardening issue asks for).
TARGET_S = 0.5
#: On a GPU a launch aims at a second: it has a launch and a copy back to amortise, and
#: a second of an H100 is about 2.5e5 blocks, the threads it runs at once.
TARGET_S_CUDA = 1.0
#: A call grows by at most this factor over the last one: a throughput measured on a
#: short call is noisy, and the next direction's paths may cost more.
GROWTH = 4
#: The most blocks of one call on the CPU (2^16 blocks, 2.7e8 paths) and on a GPU (2^22):
#: caps that time sizing reaches only for the cheapest walks, far past any call overhead.
MOST_BLOCKS = {"cpu": 2 ** 16, "cuda": 2 ** 22}
#: The first call of a run on a GPU (before any throughput is known): a small launch,
#: 1.7e7 paths, a few milliseconds on any current GPU.
FIRST_BLOCKS_CUDA = 4096
#: A call shorter than this says little about the throughput (timer and call overhead):
#: it lets the next call grow by :data:`GROWTH` whatever its rate.
SHORTEST_MEASURED_S = 0.01


class ChunkSizer:
    """Blocks per walk call: a fixed number, or sized to about ``target_s`` seconds.

    Parameters
    ----------
    fixed : int, optional
        Blocks per call (``--chunk-blocks``); then the sizer never changes it.
    device : str
        ``"cpu"`` or ``"cuda"``: sets the target time, the first call and the cap.
    n_slots : int
        The CPU's thread slots: every call is a multiple of them, at least one block each
        (a call of fewer blocks leaves threads idle: Smith's walk at GGX alpha = 1000 ran at
        half speed in calls of one block on two threads). A GPU's threads are its launch's.

    Attributes
    ----------
    blocks : int
        The size of the next call.
    """

    def __init__(self, fixed: int | None = None, device: str = "cpu", n_slots: int = 1):
        self.fixed = None if fixed is None else int(fixed)
        self.target_s = TARGET_S_CUDA if device == "cuda" else TARGET_S
        self.most = MOST_BLOCKS.get(device, MOST_BLOCKS["cpu"])
        #: the least blocks of a call, and the unit its size is a multiple of
        self.least = 1 if device == "cuda" else max(1, int(n_slots))
        first = FIRST_BLOCKS_CUDA if device == "cuda" else self.least
        self.blocks = self.fixed if self.fixed is not None else min(first, self.most)

    def _whole(self, blocks: int) -> int:
        """``blocks`` rounded down to whole rounds of the thread slots, at least one round."""
        return max(self.least, blocks // self.least * self.least)

    def observe(self, n_blocks: int, seconds: float) -> None:
        """Size the next call from a call of ``n_blocks`` blocks that took ``seconds``.

        A call that was cut short (by a direction's end or a target-error check) measures
        the throughput as well as a full one; the next call aims at :attr:`target_s` at that
        rate, growing by at most :data:`GROWTH` over the larger of the call measured and
        the current size, within ``[least, most]`` and in whole rounds of the thread slots.
        """
        if self.fixed is not None or n_blocks < 1:
            return
        most = min(self.most, GROWTH * max(int(n_blocks), self.blocks))
        if seconds < SHORTEST_MEASURED_S:
            self.blocks = self._whole(max(self.blocks, most))
            return
        self.blocks = self._whole(min(most, int(n_blocks * self.target_s / seconds)))

    def aim(self, target_s: float) -> None:
        """Aim each call at ``target_s`` seconds instead (e.g. a Dask task, which should
        take about a second on its worker to amortise the task's overhead)."""
        self.target_s = float(target_s)

    def new_direction(self) -> None:
        """A new incident direction's paths may cost more than the last one's: its first
        call is a quarter of the last (then grows back as measured)."""
        if self.fixed is None:
            self.blocks = self._whole(self.blocks // GROWTH)


__all__ = ["ChunkSizer", "FIRST_BLOCKS_CUDA", "GROWTH", "MOST_BLOCKS", "TARGET_S", "TARGET_S_CUDA"]
