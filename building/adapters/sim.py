"""Simulated lift and door: state machines driven by time, for the demo and the tests.

Pure: given what the device was doing, what it is asked, and how much time passed, the state
it is in now. building.services.sim_step stores the result and reports it exactly as a real
controller's report is applied, so everything downstream is the same code.

A lift: doors open or close in DOOR_SECONDS; the car moves only with its doors closed, one
floor per `seconds_per_floor`; stopped at the requested floor, it opens the doors if asked.
A door: opens or closes in DOOR_SECONDS.
`speedup` runs the whole device that many times faster (settings.BUILDING_SIM_SPEEDUP: tests
whose robots are simulated faster than real time ride lifts as fast as they drive).
"""

from dataclasses import dataclass, replace
from datetime import datetime, timedelta

DOOR_SECONDS = 2.0
MIN_SECONDS_PER_FLOOR = 1.0  # a map without ride times still takes time to move

CLOSED, MOVING, OPEN = "closed", "moving", "open"
STOPPED, UP, DOWN = "stopped", "up", "down"


@dataclass(frozen=True)
class SimState:
    level: int | None  # the car's floor level (lifts); None for doors
    door: str  # closed, moving, open
    motion: str  # stopped, up, down
    since: datetime  # when the current door or car motion began


def sim_advance(
    state: SimState,
    *,
    target: int | None,
    door_open: bool,
    now: datetime,
    seconds_per_floor: float,
    speedup: float = 1.0,
) -> SimState:
    """The state at `now`, stepping through every transition that time allows."""
    for _ in range(1000):  # bounded: each pass either moves on or stops
        following = _next(
            state, target=target, door_open=door_open, spf=seconds_per_floor, speedup=speedup
        )
        if following is None:
            return state
        due, after = following
        if due > now:
            return state
        state = after
    return state


def _next(state: SimState, *, target, door_open, spf, speedup) -> tuple[datetime, SimState] | None:
    """The next transition (when it happens, the state after), or None if at rest."""
    spf = max(spf, MIN_SECONDS_PER_FLOOR) / speedup
    door_done = state.since + timedelta(seconds=DOOR_SECONDS / speedup)
    must_move = state.level is not None and target is not None and state.level != target
    if state.door == MOVING:  # which way follows from what is asked now
        opened = door_open and not must_move
        return door_done, replace(state, door=OPEN if opened else CLOSED, since=door_done)
    if must_move:
        if state.door == OPEN:  # close first; start closing now
            return state.since, replace(state, door=MOVING)
        step = 1 if target > state.level else -1
        if state.motion == STOPPED:
            motion = UP if step > 0 else DOWN
            return state.since, replace(state, motion=motion)
        arrive = state.since + timedelta(seconds=spf)
        stopped = state.level + step == target
        return arrive, replace(
            state,
            level=state.level + step,
            motion=STOPPED if stopped else state.motion,
            since=arrive,
        )
    if state.motion != STOPPED:
        return state.since, replace(state, motion=STOPPED)
    if door_open and state.door == CLOSED or not door_open and state.door == OPEN:
        return state.since, replace(state, door=MOVING)
    return None
