"""core.memo: a read done once within a scope, every time outside one."""

from core import memo


def _counting():
    reads = []

    def read():
        reads.append(1)
        return len(reads)

    return reads, read


def test_within_a_scope_a_key_is_read_once_and_each_key_on_its_own():
    reads, read = _counting()
    with memo.scope():
        assert memo.once("a", read) == 1
        assert memo.once("a", read) == 1
        assert memo.once("b", read) == 2
    assert len(reads) == 2


def test_outside_a_scope_and_after_one_it_reads_every_time():
    reads, read = _counting()
    assert memo.once("a", read) == 1
    assert memo.once("a", read) == 2
    with memo.scope():
        assert memo.once("a", read) == 3
    assert memo.once("a", read) == 4


def test_a_scope_inside_another_keeps_to_the_outer_one():
    reads, read = _counting()
    with memo.scope():
        memo.once("a", read)
        with memo.scope():
            assert memo.once("a", read) == 1
        assert memo.once("a", read) == 1
    assert len(reads) == 1
