"""Histograms of durations, summed over days, and the percentiles read from them.

A histogram is {bucket: count} with string keys (it is stored as JSON in a day's roll-up):
bucket b holds the durations that round to b × width. A percentile read from it is PostgreSQL's
PERCENTILE_CONT (linear interpolation between the two nearest ranks) over the rounded
durations, so it is within width / 2 of the exact one over the raw durations.
"""


def figures_add(into: dict, part: dict) -> dict:
    """Add `part` into `into`, key by key (numbers sum, dicts recurse): merging days."""
    for key, value in part.items():
        if isinstance(value, dict):
            figures_add(into.setdefault(key, {}), value)
        else:
            into[key] = into.get(key, 0) + value
    return into


def percentile(histogram: dict[str, int], fraction: float, *, width: float) -> float | None:
    """The `fraction` percentile of the durations counted in `histogram` (None if empty)."""
    buckets = sorted((int(bucket), count) for bucket, count in histogram.items() if count)
    total = sum(count for _, count in buckets)
    if not total:
        return None
    position = (total - 1) * fraction
    low = int(position)
    high = min(low + 1, total - 1)
    low_value = high_value = None
    seen = 0
    for bucket, count in buckets:
        seen += count
        if low_value is None and seen > low:
            low_value = bucket
        if seen > high:
            high_value = bucket
            break
    value = low_value + (high_value - low_value) * (position - low)
    return value * width
