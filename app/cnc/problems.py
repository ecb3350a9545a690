"""Problems found in a program: where (block, field), how bad, what is wrong, which rule.

Every validation rule has a stable `Rule` code, so the bad-input corpus can prove that each
rule is exercised by at least one bad program.

Some errors stop only the consumers that need what is missing (DESIGN.md §1: "a need of
one target never blocks another"): a tool without RPM is the data-block control's
emergency stop and a G-code target's missing S word, but the JSON document, the ProtoTRAK
Plus events (a 2-axis control with a manual spindle), the preview and the cycle time do not
need speeds. Such a problem carries its `need`; `blocking` picks the errors that stop a
consumer with given needs.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass


class Need(enum.Enum):
    """Something a consumer needs from a program that not every consumer needs."""

    SPINDLE_SPEEDS = "spindle speeds (RPM in Data Block 0)"
    CALIBRATED_TOOLS = "calibrated tools (TCAL in Data Block 0)"


# What the data-block control itself (seed 001) needs to run a program: `check` and the
# editor's verdict judge a program as that control would. (It calibrates tools at the
# machine, so TCAL is not among them.)
CONTROL_NEEDS = frozenset({Need.SPINDLE_SPEEDS})


class Severity(enum.Enum):
    """An error stops the program from running; a warning is worth the programmer's look."""

    ERROR = "error"
    WARNING = "warning"


class Rule(enum.Enum):
    """Each validation rule; the value is the code the bad-input corpus refers to."""

    NAME = "name"
    PART_NUMBER = "part-number"
    MISSING = "missing"
    RANGE = "range"
    RESOLUTION = "resolution"
    FEED_STEP = "feed-step"
    TOOL_DUPLICATE = "tool-duplicate"
    TOOL_NO_RPM = "tool-no-rpm"
    TOOL_NO_TCAL = "tool-no-tcal"
    TOOL_NO_DIAMETER = "tool-no-diameter"
    TOOL_NAME = "tool-name"
    TOOL_CHANGE_IN_SEQUENCE = "tool-change-in-sequence"
    LOOP_WITHOUT_REP = "loop-without-rep"
    REP_WITHOUT_LOOP = "rep-without-loop"
    LOOP_TOO_DEEP = "loop-too-deep"
    LOOP_QUALIFIER = "loop-qualifier"
    ABS_IN_LOOP = "abs-in-loop"
    STOP_QUALIFIER = "stop-qualifier"
    BOLT_CIR_ORDER = "bolt-cir-order"
    MILL_ORDER = "mill-order"
    ARC_END_ORDER = "arc-end-order"
    QCIR_CENTRE_LINES = "qcir-centre-lines"
    ARC_RADIUS = "arc-radius"
    ZERO_LENGTH = "zero-length"
    PECKS_NOT_DRILL = "pecks-not-drill"
    COMP_NOT_DRILL = "comp-not-drill"
    COMP_WITHOUT_MILL = "comp-without-mill"
    DEPTH_ORDER = "depth-order"
    TWO_AXIS_MIXED = "two-axis-mixed"
    COPY_1 = "copy-1"
    COPY_2 = "copy-2"
    COPY_3 = "copy-3"
    COPY_4 = "copy-4"
    COPY_RANGE_ORDER = "copy-range-order"
    COPY_PENDING = "copy-pending"
    INSIDE_ANGLE = "inside-angle"
    COMP_DIVOT = "comp-divot"
    COMP_GOUGE = "comp-gouge"
    COMP_ARC_TOO_SMALL = "comp-arc-too-small"
    ROUTINE_TOO_SMALL = "routine-too-small"
    FRAME_CORNER = "frame-corner"
    RAMP_ENTRY = "ramp-entry"
    CORNER_UNREACHABLE = "corner-unreachable"
    POCKET_TOOL = "pocket-tool"
    POCKET_ORDER = "pocket-order"
    POCKET_CONTOUR = "pocket-contour"
    POCKET_ISLAND = "pocket-island"
    POCKET_NARROW = "pocket-narrow"
    POCKET_STEP = "pocket-step"
    POCKET_TWO_AXIS = "pocket-two-axis"
    COMP_ON_ROUTINE = "comp-on-routine"
    MESSAGE = "message"
    PILOT = "pilot"
    BELOW_STOCK = "below-stock"
    MATERIAL = "material"
    TOOL_THREAD = "tool-thread"
    TAP_FEED = "tap-feed"
    TAP_HAND = "tap-hand"
    TOO_LARGE = "too-large"
    UNDER_DETERMINED = "under-determined"
    TANGENCY = "tangency"
    CORNER = "corner"
    HELIX_TOOL = "helix-tool"
    ENGRAVE_TEXT = "engrave-text"


@dataclass(frozen=True, slots=True)
class Problem:
    """One problem. `block` is None for the program as a whole, 0 for Data Block 0.

    `field` is the control's prompt for the field at fault (`FEEDR XY`), or None when the
    problem belongs to the whole block.
    """

    block: int | None
    field: str | None
    severity: Severity
    message: str
    rule: Rule
    need: Need | None = None

    @property
    def location(self) -> str:
        """`block 12, FEEDR XY`, `Data Block 0, TOOL 3 RPM`, or `program, NAME`."""
        if self.block is None:
            where = "program"
        elif self.block == 0:
            where = "Data Block 0"
        else:
            where = f"block {self.block}"
        return f"{where}, {self.field}" if self.field else where

    def __str__(self) -> str:
        prefix = "warning: " if self.severity is Severity.WARNING else ""
        return f"{self.location}: {prefix}{self.message}"


def blocking(problems: list[Problem], needs: frozenset[Need] = CONTROL_NEEDS) -> list[Problem]:
    """The errors that stop a consumer with `needs`: every error that names no need, and
    those whose need is one of `needs` (by default the data-block control's)."""
    return [
        p for p in problems if p.severity is Severity.ERROR and (p.need is None or p.need in needs)
    ]


def has_errors(problems: list[Problem], needs: frozenset[Need] = CONTROL_NEEDS) -> bool:
    """True when any problem is an error for a consumer with `needs` (see `blocking`)."""
    return bool(blocking(problems, needs))
