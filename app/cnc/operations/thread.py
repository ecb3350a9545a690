"""THREAD MILL's motion (blocks.ThreadMill): the passes of a single-point thread mill.

Lengths in integer nanometres. The thread's lead comes from app.cnc.tools.lead_per_rev
(threads per inch in an inch block, mm in a mm block). Each pass:

- comes down at rapid, at its approach point, to where the thread starts (Z DN for a
  thread cut upwards, Z UP for one cut downwards): the bore's centre for an internal
  thread (the tool fits down the minor diameter: validation), outside the boss for an
  external one, the tool's edge `clear` beyond the major diameter;
- enters along a half circle tangent to the thread at 3 o'clock, a quarter of the lead
  along Z (the lead-in: the cut's depth builds up from nothing, no dwell mark);
- follows the helix, one row a turn (app/cnc/operations/helix.py), to a quarter of the lead short of
  the thread's other end;
- leaves along a half circle tangent to it, a quarter of the lead along Z, back to the
  centre (internal) or out to `clear` beyond the major diameter (external).

Passes are evenly spaced in radial depth to the full depth of an ISO/UN basic profile,
H = √3/2 × lead: 5/8 H for an internal thread (from the minor diameter out to the major),
17/24 H for an external one (from the major in to the minor). The tool's centre goes round
at the radius where its cutting diameter (its DIA) reaches that depth.

Direction: the tool goes round as CIRCLE INSIDE (internal) or OUTSIDE (external) does for
climb or conventional (`mill.routine_clockwise`); a right-hand thread rises going round
counter-clockwise (seen from above), a left-hand one going clockwise. So a right-hand
internal thread cut climb with a clockwise spindle goes G3, bottom-up (docs/readings.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from app.cnc import limits
from app.cnc.blocks import Placement, Program, ThreadMill, ThreadPlace
from app.cnc.compiler import retract_height
from app.cnc.cost import POS_ROWS
from app.cnc.operations.helix import Point, helix_ends
from app.cnc.routines import routine_clockwise
from app.cnc.tools import Hand, PitchUnit, lead_per_rev
from app.cnc.units import Units, to_nm

if TYPE_CHECKING:
    from app.cnc.compiler import _Compiler as Compiler

INTERNAL_DEPTH = 5 / 8  # of H: the basic internal thread's depth (ISO 68-1, UN)
EXTERNAL_DEPTH = 17 / 24  # of H: the basic external thread's


@dataclass(frozen=True)
class Arc:
    """An arc row: to `end` about `centre`, clockwise or not (helical where Z changes)."""

    end: Point
    centre: tuple[int, int]
    clockwise: bool


@dataclass(frozen=True)
class ThreadPass:
    """One radial pass: rapid down at `approach` to `z_start`, then `lead_in`, the helix's
    `turns`, `lead_out` (all arcs)."""

    approach: tuple[int, int]
    z_start: int
    lead_in: Arc
    turns: tuple[Arc, ...]
    lead_out: Arc


def thread_clear() -> int:
    """How far (nm) an external thread's lead-in starts beyond its major diameter: 0.050 in."""
    return to_nm(limits.THREAD_CLEAR_INCH, Units.INCH)


def thread_lead(block: ThreadMill) -> int:
    """A THREAD MILL's lead in nm: 1/PITCH in in an inch block, PITCH mm in a mm block."""
    unit = PitchUnit.TPI if block.units is Units.INCH else PitchUnit.MM
    return round(lead_per_rev(block.pitch, unit, block.units) * block.units.nm)


def thread_depth(lead: int, internal: bool) -> float:
    """The basic profile's depth (nm) of a thread of `lead` nm."""
    height = math.sqrt(3) / 2 * lead
    return height * (INTERNAL_DEPTH if internal else EXTERNAL_DEPTH)


def lead_rise(lead: int) -> int:
    """How far (nm) a pass's lead-in and lead-out each go along Z: a quarter of the lead.
    The helix's turns stop that far short of both ends of the thread."""
    return lead // 4


def full_form_bottom(z_up: int, z_dn: int, lead: int) -> int:
    """The lowest Z (nm) down to which a thread from `z_up` to `z_dn` of `lead` has its full
    form all round. The helix goes one lead a turn and stops `lead_rise` short of Z DN (the
    lead-in or lead-out takes it the rest of the way), so where its last turn ends the turn
    before passed a lead higher: a lead and a quarter above Z DN. Below that the thread runs
    out, partly cut, as a thread mill's last turn leaves it; nothing is cut below Z DN. A
    helix shorter than a turn (a thread shorter than a lead and a half) goes round only part
    of the way: no depth has the full form all round, and this is `z_up`."""
    rise = lead_rise(lead)
    bottom = z_dn + lead + rise
    return bottom if bottom <= z_up - rise else z_up


def thread_passes(
    centre: tuple[int, int],
    major: int,
    tool_diameter: int,
    lead: int,
    z_up: int,
    z_dn: int,
    passes: int,
    internal: bool,
    clockwise: bool,
    right_hand: bool,
    clear: int,
) -> list[ThreadPass]:
    """The passes of a thread (see the module docstring). `major`, `tool_diameter`, `lead`,
    `clear` in nm, Z UP above Z DN by more than half the lead (validation).

    Raises ValueError for a lead that is not positive or no passes."""
    if lead <= 0 or passes < 1:
        raise ValueError("a thread needs a lead more than 0 and one pass at least")
    cx, cy = centre
    depth = thread_depth(lead, internal)
    tool_r = tool_diameter / 2
    up = (not clockwise) if right_hand else clockwise
    way = 1 if up else -1
    z_start, z_end = (z_dn, z_up) if up else (z_up, z_dn)
    quarter = lead_rise(lead)
    found = []
    for k in range(1, passes + 1):
        short = depth * (passes - k) / passes  # the depth this pass leaves for the next
        if internal:
            radius = major / 2 - tool_r - short
            lead_r = radius / 2  # from the centre, half way out
            approach = centre
        else:
            radius = major / 2 - depth + tool_r + short
            lead_r = (major / 2 + tool_r + clear - radius) / 2
            approach = (round(cx + radius + 2 * lead_r), cy)
        start = (round(cx + radius), cy, z_start + way * quarter)
        lead_centre = (round(cx + radius + (-lead_r if internal else lead_r)), cy)
        lead_in = Arc(start, lead_centre, clockwise if internal else not clockwise)
        ends = helix_ends(start, centre, z_end - way * quarter, lead, clockwise)
        turns = tuple(Arc(end, centre, clockwise) for end in ends)
        ex, ey, _ = ends[-1] if ends else start
        angle = math.atan2(ey - cy, ex - cx)
        if internal:
            out_centre = (round((cx + ex) / 2), round((cy + ey) / 2))
            out_end = (cx, cy, z_end)
        else:
            ux, uy = math.cos(angle), math.sin(angle)
            out_centre = (round(ex + lead_r * ux), round(ey + lead_r * uy))
            out_end = (round(ex + 2 * lead_r * ux), round(ey + 2 * lead_r * uy), z_end)
        lead_out = Arc(out_end, out_centre, clockwise if internal else not clockwise)
        found.append(ThreadPass(approach, z_start, lead_in, turns, lead_out))
    return found


def estimate_moves(program: Program, block: ThreadMill) -> int:
    """About how many moves a THREAD MILL makes (its `Kind.cost`, read by cost.py): each
    pass its turns down the depth and its approach, from its numbers alone."""
    units = block.units
    depth = max(to_nm(block.z_up, units) - to_nm(block.z_dn, units), 0)
    turns = depth // max(thread_lead(block), 1) + 2
    return block.passes * (turns + POS_ROWS + 2) + POS_ROWS


def cut(c: Compiler, number: int, block: ThreadMill, centre: tuple[int, int]) -> None:
    """THREAD MILL about `centre` (app/cnc/operations/thread.py says the motion). A block whose
    tool has no DIA, or whose thread is shorter than half its lead, makes no moves:
    validation reports it."""
    units = block.units
    tool_diameter = c.tool_diameter(block.tool)
    lead = thread_lead(block)
    z_up, z_dn = to_nm(block.z_up, units), to_nm(block.z_dn, units)
    if tool_diameter is None or z_up - z_dn <= lead // 2:
        return
    internal = block.place is ThreadPlace.INTERNAL
    placement = Placement.INSIDE if internal else Placement.OUTSIDE
    clockwise = routine_clockwise(placement, block.milling, c.spindle_rpm(block.tool))
    passes = thread_passes(
        centre,
        to_nm(block.diameter, units),
        tool_diameter,
        lead,
        z_up,
        z_dn,
        block.passes,
        internal,
        clockwise,
        block.hand is Hand.RIGHT,
        thread_clear(),
    )
    c.use_tool(number, block.tool)
    feed = to_nm(block.feed_xy, units)
    c.retract = retract_height(z_up, c.z_retract)
    for cut in passes:
        c.position(number, cut.approach, c.retract)
        c.rapid_z(number, cut.z_start)
        lead_in = cut.lead_in
        c.helix_to(number, lead_in.end, lead_in.centre, lead_in.clockwise, feed, "lead-in")
        for turn in cut.turns:
            c.helix_to(number, turn.end, turn.centre, turn.clockwise, feed)
        out = cut.lead_out
        c.helix_to(number, out.end, out.centre, out.clockwise, feed, "lead-out")
    c.retract_up(number)
