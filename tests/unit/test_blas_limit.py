"""A bake keeps numpy's BLAS on one thread (clothtool.bake.bake): idle BLAS threads woken
by every small matrix product took a fifth of a big bake's CPU."""

from __future__ import annotations

from threadpoolctl import threadpool_info, threadpool_limits

import clothtool.bake as bake_module


def _blas_threads() -> list[int]:
    return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]


def test_bake_runs_blas_on_one_thread_and_gives_the_threads_back(monkeypatch):
    seen = []

    def fake_bake(scene, output, options):
        seen.extend(_blas_threads())
        return "baked"

    monkeypatch.setattr(bake_module, "_bake", fake_bake)
    with threadpool_limits(limits=2, user_api="blas"):  # BLAS on two threads, whatever the machine
        before = _blas_threads()
        for _ in range(2):  # the second bake reuses the process's thread-pool controller
            assert bake_module.bake(None, "null") == "baked"
        after = _blas_threads()
    assert before and set(before) == {2} and after == before
    assert seen == [1] * (2 * len(before))
