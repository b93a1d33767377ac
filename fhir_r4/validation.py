"""A body checked against the FHIR R4 (R4B) model of its resource before any mapping, with
`fhir.resources`: unknown elements, wrong types and malformed values are refused, each named by
its FHIRPath. Size, depth and text were bounded when the body was parsed (core/jsonbody.py)."""

from fhir.resources.R4B import get_fhir_model_class
from pydantic import ValidationError

from fhir_r4.outcomes import FhirError, Issue, fhirpath

# What a pydantic error type means in FHIR's words (OperationOutcome.issue.code).
_CODES = {"missing": "required", "extra_forbidden": "structure"}
_WORDS = {"extra_forbidden": "unknown element", "missing": "required"}
MESSAGE_MAX = 300


def resource_validated(data, resource_type: str):
    """The `fhir.resources` model of `data`, which must be a `resource_type`; else FhirError
    400 naming every problem found."""
    if not isinstance(data, dict):
        raise FhirError.one(400, "structure", f"the body must be a {resource_type} (an object)")
    sent = data.get("resourceType")
    if sent != resource_type:
        why = f"the body is a {sent}, not a {resource_type}" if sent else "resourceType missing"
        raise FhirError.one(400, "invalid", why, "resourceType")
    _contained_check(data, resource_type)
    model = get_fhir_model_class(resource_type)
    try:
        return model.model_validate(data)
    except ValidationError as invalid:
        issues = [_issue(error, resource_type) for error in invalid.errors()]
        raise FhirError(400, issues) from None
    except (ValueError, TypeError, KeyError):  # the library's own refusals, outside pydantic's
        words = f"not a valid {resource_type}"
        raise FhirError.one(400, "structure", words, resource_type) from None


def _contained_check(data: dict, resource_type: str) -> None:
    """Contained resources of a type FHIR does not know make the library fail outside its
    validation: refuse them by name first."""
    contained = data.get("contained")
    if not isinstance(contained, list):
        return
    for n, item in enumerate(contained):
        kind = item.get("resourceType") if isinstance(item, dict) else None
        if not isinstance(kind, str) or not _known(kind):
            path = f"{resource_type}.contained[{n}]"
            raise FhirError.one(400, "structure", "not a FHIR R4 resource type", path)


def _known(kind: str) -> bool:
    try:
        get_fhir_model_class(kind)
    except (ValueError, KeyError):
        return False
    return True


def _issue(error: dict, resource_type: str) -> Issue:
    kind = error.get("type", "")
    words = _WORDS.get(kind) or str(error.get("msg", "invalid")).removeprefix("Value error, ")
    return Issue(
        code=_CODES.get(kind, "value"),
        diagnostics=words[:MESSAGE_MAX],
        expression=(fhirpath(resource_type, error.get("loc", ())),),
    )
