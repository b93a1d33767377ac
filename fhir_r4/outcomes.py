"""Every refusal of the FHIR endpoint is an OperationOutcome (docs/integrators/fhir.md,
"Errors"): its HTTP status, and one issue per problem naming where it is, as a FHIRPath
expression into the resource sent (`Task.input[1].valueReference`), or `http.<name>` for a
header or search parameter."""

from dataclasses import dataclass, field

from core.errors import printable


@dataclass(frozen=True)
class Issue:
    code: str  # FHIR IssueType: structure, required, value, invalid, not-found, ...
    diagnostics: str
    expression: tuple[str, ...] = ()
    severity: str = "error"

    def as_fhir(self) -> dict:
        issue = {"severity": self.severity, "code": self.code}
        issue["diagnostics"] = printable(self.diagnostics)
        if self.expression:
            issue["expression"] = [printable(path) for path in self.expression]
        return issue


@dataclass
class FhirError(Exception):
    """Refuse the request: `status` and its issues. Raised before anything is written, or
    inside the transaction that then rolls back."""

    status: int
    issues: list[Issue] = field(default_factory=list)
    headers: dict = field(default_factory=dict)

    @classmethod
    def one(cls, status: int, code: str, diagnostics: str, *expression: str, **headers):
        return cls(status, [Issue(code, diagnostics, tuple(expression))], headers)


def outcome(issues: list[Issue]) -> dict:
    return {"resourceType": "OperationOutcome", "issue": [issue.as_fhir() for issue in issues]}


def fhirpath(resource_type: str, loc) -> str:
    """("input", 1, "valueReference") -> "Task.input[1].valueReference"."""
    path = resource_type
    for part in loc:
        path += f"[{part}]" if isinstance(part, int) else f".{part}"
    return path
