"""The kernels' thread slots (vcavity/kernels/slots.py: ``run_slots``; loop.py: ``SlotKernel``):
every slot walked once, slot 0 in the calling thread (alone while the walk compiles), the
others on other threads, all at once; a slot's exception reaches the caller after the
others end; and the compiled walks release the GIL, so the slots really run at once.

No timing: concurrency is shown by events one slot waits for and another sets (a wait
times out only when the behaviour is broken).
"""

import concurrent.futures
import math
import sys
import threading

import numpy as np
import pytest

from vcavity.facet import registry as facets
from vcavity.kernels import loop, slots, walks
from vcavity.microfacet import registry as distributions

WAIT_S = 30.0  # how long a slot waits for another before the test calls it broken


def test_each_slot_runs_once_slot_0_in_the_calling_thread_the_others_on_other_threads():
    seen = {}
    lock = threading.Lock()

    def walk_slot(slot):
        with lock:
            seen.setdefault(slot, []).append(threading.get_ident())

    slots.run_slots(walk_slot, 5, compiled=True)
    assert sorted(seen) == list(range(5)) and all(len(ids) == 1 for ids in seen.values())
    assert seen[0] == [threading.get_ident()]
    others = [ids[0] for slot, ids in seen.items() if slot != 0]
    assert threading.get_ident() not in others  # (a pool thread done with one slot may take the next)


@pytest.mark.parametrize("n_slots", [0, 1])
def test_no_slot_or_one_slot_needs_no_thread(n_slots):
    seen = []
    slots.run_slots(lambda slot: seen.append((slot, threading.get_ident())), n_slots, compiled=True)
    assert seen == [(0, threading.get_ident())][:n_slots]


def test_compiled_walks_run_their_slots_at_once():
    """Each slot waits for the other two to have started: only possible if all overlap."""
    barrier = threading.Barrier(3, timeout=WAIT_S)
    passed = []

    def walk_slot(slot):
        barrier.wait()  # BrokenBarrierError after WAIT_S if the slots run one after another
        passed.append(slot)

    slots.run_slots(walk_slot, 3, compiled=True)
    assert sorted(passed) == [0, 1, 2]


class _RecordingPool:
    """Stands in for the slots' thread pool: notes each submit, then runs it on a thread."""

    def __init__(self):
        self.submitted = []
        self.pool = concurrent.futures.ThreadPoolExecutor(max_workers=4)

    def submit(self, function, slot):
        self.submitted.append(slot)
        return self.pool.submit(function, slot)


def test_a_walk_not_yet_compiled_walks_slot_0_alone_first(monkeypatch):
    """Its compile (or cache load) then happens once, in the calling thread: no other slot
    is even handed to the pool before slot 0 has returned."""
    pool = _RecordingPool()
    monkeypatch.setattr(slots, "_slot_pool", lambda: pool)
    seen_by_slot_0 = []

    def walk_slot(slot):
        if slot == 0:
            seen_by_slot_0.append((threading.get_ident(), list(pool.submitted)))

    slots.run_slots(walk_slot, 3, compiled=False)
    assert seen_by_slot_0 == [(threading.get_ident(), [])] and pool.submitted == [1, 2]
    # compiled: the other slots are handed out first, so that they run beside slot 0
    seen_by_slot_0.clear()
    pool.submitted.clear()
    slots.run_slots(walk_slot, 3, compiled=True)
    assert seen_by_slot_0 == [(threading.get_ident(), [1, 2])]
    pool.pool.shutdown()


def test_an_exception_in_a_slot_reaches_the_caller_after_the_other_slots_end():
    finished = []
    release = threading.Event()

    def walk_slot(slot):
        if slot == 2:
            raise ValueError("slot 2 failed")
        if slot == 1:
            release.wait(WAIT_S)  # still running when slot 2 has failed
        finished.append(slot)
        if slot == 0:
            release.set()

    with pytest.raises(ValueError, match="slot 2 failed"):
        slots.run_slots(walk_slot, 3, compiled=True)
    assert sorted(finished) == [0, 1]


def _mirror_walk(name):
    dist_kind, params = distributions.params_from("beckmann", {"alpha_x": 0.5, "alpha_y": 0.5})
    facet_kind, variant, facet_data = facets.prepare("mirror", {})
    return walks.get(name, dist_kind, facet_kind, variant), params, facet_data


def _call(incident, key, n_blocks, n_paths, params, facet_data, max_order, resolution, n_slots):
    return walks.WalkCall(incident=incident, direction_key=np.uint64(key), first_block=0, n_blocks=n_blocks,
                          n_paths=n_paths, params=params, facet_data=facet_data, max_bounces=50, max_order=max_order,
                          resolution=resolution, n_slots=n_slots, weight_scale=65536.0)


@pytest.mark.parametrize("name", ["v-cavity", "smith", "paper"])
def test_the_compiled_walks_release_the_gil(name):
    """While this thread is inside a walk, another Python thread runs.

    Python's switch interval is set to an hour, so this thread gives up the GIL only when
    it blocks or when the compiled walk releases it: the other thread, woken by an event
    set just before the walk, can then record that the walk has not returned yet. A walk
    holding the GIL lets it run only after the walk, and it records that.
    """
    walk, params, facet_data = _mirror_walk(name)
    kernel = walk.kernel
    incident = np.array([math.sin(0.5), 0.0, math.cos(0.5)])
    max_order, resolution = 2, 5
    rows = kernel.slot_rows(kernel.outputs(1, max_order, resolution), 0)
    # slot 0 of 1: 400 blocks of the direction's paths, 40-100 ms (a thread wakes in ~0.1 ms)
    call = _call(incident, 5, 400, 400 * 4096, params, facet_data, max_order, resolution, 1)
    walk_args = (0, *loop.arguments(call), *rows)
    kernel.walk(*walk_args)  # compiled (or loaded) first
    entered, walk_returned, during = threading.Event(), [False], []

    def watcher():
        entered.wait(WAIT_S)
        during.append(not walk_returned[0])

    interval = sys.getswitchinterval()
    thread = threading.Thread(target=watcher)
    thread.start()
    sys.setswitchinterval(3600.0)
    try:
        entered.set()
        kernel.walk(*walk_args)
        walk_returned[0] = True
    finally:
        sys.setswitchinterval(interval)
        thread.join(WAIT_S)
    assert during == [True]


@pytest.mark.parametrize("name", ["v-cavity", "smith", "paper"])
def test_the_tallies_do_not_depend_on_the_slots_even_slots_without_blocks(name):
    """3 blocks (the last one short) on 1, 2, 3 and 5 slots: the same sums; a slot without
    blocks (5 slots) keeps rows of zeros and needs no thread."""
    walk, params, facet_data = _mirror_walk(name)
    incident = np.array([math.sin(1.0), 0.0, math.cos(1.0)])
    n_paths = 2 * 4096 + 1000

    def call(n_slots):
        return walk.kernel(_call(incident, 11, 3, n_paths, params, facet_data, 3, 6, n_slots))

    one = call(1)
    columns = {name: k for k, name in enumerate(walk.stats)}
    lost = [columns[c] for c in ("unbinned", "absorbed", "truncated", "degenerate")]  # every path once
    assert int(one[-1][0, lost].sum()) + int(one[0].sum()) == n_paths
    for n_slots in (2, 3, 5):
        out = call(n_slots)
        for tally, reference in zip(out[:-1], one[:-1]):
            assert np.array_equal(tally.sum(axis=0), reference[0])
        stats, reference = out[-1], one[-1][0]
        deepest = columns["max_bounces"]
        assert stats[:, deepest].max() == reference[deepest]
        others = [c for c in range(stats.shape[1]) if c != deepest]
        assert np.array_equal(stats[:, others].sum(axis=0), reference[others])
        assert not out[0][3:].any() and not stats[3:].any()  # slots 3 and 4: no block
