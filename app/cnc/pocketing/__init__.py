"""Irregular pockets with islands: offset passes, finishing passes, links (issue 22).

    plan_pocket(boundary, islands, *, tool_radius, step_over, finish_allowance=0,
                milling=CLIMB, rpm=None, block=0, units=INCH,
                chordal_tolerance=500) -> PocketPlan
    pass_levels(plan, z_up, z_dn, pecks=1, floor_allowance=0) -> tuple[PassLevel, ...]

Pure core: no web, database or serial code. Regions and their topology come from pyclipper
(see `regions.py` for why); passes are exact lines and arcs where the offset is one
(`exact.py`), else polylines within the stated chordal tolerance. See docs/pocketing.md.
"""

from app.cnc.pocketing.model import (
    Link,
    LinkKind,
    Pass,
    PassKind,
    PassLevel,
    PocketFinding,
    PocketIssue,
    PocketPlan,
)
from app.cnc.pocketing.plan import DEFAULT_CHORDAL_TOLERANCE, pass_levels, plan_pocket

__all__ = [
    "DEFAULT_CHORDAL_TOLERANCE",
    "Link",
    "LinkKind",
    "Pass",
    "PassKind",
    "PassLevel",
    "PocketFinding",
    "PocketIssue",
    "PocketPlan",
    "pass_levels",
    "plan_pocket",
]
