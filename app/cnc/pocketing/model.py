"""What the pocket planner returns: passes, the links between them, and findings.

Lengths are nanometres (floats of the exact values; the interpreter rounds once when it
emits moves, as for every other mill path). Paths are `app.cnc.plane.Path`s: a start point
and elements (lines, or arcs with centre and direction) — the shape the interpreter cuts.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

from app.cnc.plane import Path, Pt
from app.cnc.problems import Severity


class PassKind(enum.Enum):
    """A roughing pass (`finish_allowance` off the walls or nearer the middle), or a
    finishing pass (one tool radius off the wall or an island: the finished surface)."""

    ROUGH = "rough"
    FINISH = "finish"


class LinkKind(enum.Enum):
    """How the tool gets from the end of one pass to the start of the next.

    PLUNGE: the first pass: the tool goes down at `Link.path.start` (a point where the
    whole tool fits, inside the pocket), then feeds along the link path to the pass.
    RETRACT: retract at the previous pass's end, rapid to `Link.path.start`, plunge there
    (again where the tool fits), feed along the link path — a straight move would have cut
    a wall or an island, or crossed uncut material farther than one tool diameter.
    CLEARED: feed at depth along the link path; the tool stays inside material already cut.
    CUTTING: feed at depth; the tool stays clear of walls and islands but cuts material on
    the way (a step-over no longer than the tool diameter, as the control's POCKET does).
    """

    PLUNGE = "plunge"
    RETRACT = "retract"
    CLEARED = "cleared"
    CUTTING = "cutting"


@dataclass(frozen=True)
class Link:
    """The move into a pass: `path` starts where the tool is (or goes down, for PLUNGE and
    RETRACT) and ends at the pass's start (no elements when it plunges right there)."""

    kind: LinkKind
    path: Path


@dataclass(frozen=True)
class Pass:
    """One closed pass of the tool centre at one offset from the pocket's surfaces.

    `offset`: how far (nm) the tool centre stays from the nearest wall or island surface.
    `exact`: True when the path is exact lines and arcs (the offsets of the contour's lines
    and arcs, and arcs about its corners); False when it is a polyline within the plan's
    chordal tolerance of the true offset (Clipper's ring, when it could not be matched).
    `contours`: for a finishing pass, the contours whose surface it finishes ("boundary",
    "island 1", ...), in that order.
    Elements tagged "cleanup" are out-and-back detours that reach material the rings leave
    (at sharp corners, in narrow middles); they start and end on the ring.
    """

    kind: PassKind
    path: Path
    offset: float
    exact: bool
    entry: Link
    contours: tuple[str, ...] = ()


class PocketIssue(enum.Enum):
    """What a pocket finding is about."""

    OPEN_CONTOUR = "open-contour"  # the contour does not end where it starts
    DEGENERATE = "degenerate"  # an element of zero length, or an arc whose radii differ
    SELF_INTERSECTING = "self-intersecting"  # two elements of one contour cross or overlap
    ISLAND_OUTSIDE = "island-outside"  # the island lies outside the boundary
    ISLAND_TOUCHES_WALL = "island-touches-wall"  # the island meets or crosses the wall
    ISLANDS_OVERLAP = "islands-overlap"  # two islands meet or overlap
    TOOL_TOO_LARGE = "tool-too-large"  # the tool fits nowhere in the pocket
    NARROW = "narrow"  # a place narrower than the tool: material left
    STEP_OVER = "step-over"  # step-over, tool radius or allowance out of range


@dataclass(frozen=True)
class PocketFinding:
    """A problem found, naming the contour ("boundary", "island 2") and, where there is
    one, the element (1-based index in that contour) and its block number (`block`, the
    element's own `block` field; 0 when the contour did not come from blocks)."""

    issue: PocketIssue
    severity: Severity
    message: str
    contour: str | None = None
    element: int | None = None
    block: int | None = None
    at: Pt | None = None


@dataclass(frozen=True)
class PocketPlan:
    """The passes in cutting order (each with the link into it) and the findings.

    No passes when a finding is an error. `chordal_tolerance` (nm) bounds how far a
    polyline pass (`Pass.exact` False) and the planner's area checks stray from the true
    offsets. `entry` names the entry strategy: "plunge" (straight down at a point where
    the whole tool fits, as the DRILL that starts a mill sequence does: a centre-cutting
    tool or a pre-drilled hole).
    """

    passes: tuple[Pass, ...]
    findings: tuple[PocketFinding, ...]
    chordal_tolerance: float
    entry: str = "plunge"
    # Where the tool centre may feed (nm rings, Clipper's; the planner's `moves`): a ramp
    # entry is checked against it (app.cnc.pocketing.routine).
    centres: tuple[tuple[tuple[int, int], ...], ...] = field(default=(), compare=False)

    @property
    def plunges(self) -> tuple[Pt, ...]:
        """Every point where the tool goes down, in order."""
        return tuple(
            p.entry.path.start
            for p in self.passes
            if p.entry.kind in (LinkKind.PLUNGE, LinkKind.RETRACT)
        )

    @property
    def has_errors(self) -> bool:
        return any(f.severity is Severity.ERROR for f in self.findings)


@dataclass(frozen=True)
class PassLevel:
    """The passes cut at one depth (nm, Z of the tool tip)."""

    z: int
    passes: tuple[Pass, ...]
