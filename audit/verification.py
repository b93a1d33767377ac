"""Checking the chain: every entry's hash against its content and its predecessor's hash."""

from dataclasses import dataclass

from audit import chain
from audit.models import AuditEntry, ChainHead
from audit.services import chain_anchor

BATCH = 2000


@dataclass(frozen=True)
class Verdict:
    checked: int
    first_bad_id: int | None = None
    reason: str = ""
    last_hash: str = ""

    @property
    def ok(self) -> bool:
        return self.first_bad_id is None and not self.reason


def chain_verify() -> Verdict:
    """Walk every entry in the order written; stop at the first that does not match."""
    previous, checked, last_id = chain_anchor(), 0, None
    entries = AuditEntry.objects.order_by("id").iterator(chunk_size=BATCH)
    for entry in entries:
        if entry.previous_hash != previous:
            why = "does not follow the entry before it (an entry was removed or re-ordered)"
            return Verdict(checked, entry.pk, why)
        if chain.hash_of(entry) != entry.entry_hash:
            return Verdict(checked, entry.pk, "its content does not match its hash (altered)")
        previous, checked, last_id = entry.entry_hash, checked + 1, entry.pk
    head = ChainHead.objects.filter(pk=1).first()
    if head is not None and (head.last_entry_id, head.last_hash) != (last_id, previous):
        return Verdict(checked, None, f"newer entries than #{last_id} were removed", previous)
    return Verdict(checked, last_hash=previous)
