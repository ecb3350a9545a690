"""What a consumer needs from a program beyond what every consumer needs, and who lacks it.

DESIGN.md §1: "Targets declare what they need (spindle speeds, calibrated tools ...) and
refuse a program by naming the block and the need; a need of one target never blocks
another." A need is checked once per tool, not once per block: the fix is in Data Block 0's
tool table, so each problem is put there (`TOOL 3 RPM`) and names the blocks that use the
tool.

- `Need.SPINDLE_SPEEDS`: every tool a block uses has an RPM. The data-block control stops
  (emergency stop) on a tool without one, and a target that writes S words needs it; the
  JSON document, ProtoTRAK Plus events (a manual spindle), the preview and the cycle time
  do not.
- `Need.CALIBRATED_TOOLS`: every tool that moves down in Z has its TCAL. Only a
  target whose Z words include TCAL needs it (the 1704 has no length offsets); on the
  control itself TCAL is set at the machine (seed 001 §3.4.4, "TCAL pushbutton").
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from app.cnc.blocks import Program
from app.cnc.motions import motions
from app.cnc.path import CompiledPath, Op, pieces
from app.cnc.problems import Need, Problem, Rule, Severity


def blocks_text(numbers: list[int]) -> str:
    """`block 3`, `blocks 5-8, 10 and 13`: block numbers in ranges."""
    ordered = sorted(set(numbers))
    runs: list[tuple[int, int]] = []
    for n in ordered:
        if runs and n == runs[-1][1] + 1:
            runs[-1] = (runs[-1][0], n)
        else:
            runs.append((n, n))
    parts = [str(a) if a == b else f"{a}-{b}" for a, b in runs]
    if len(parts) == 1:
        return ("block " if runs[0][0] == runs[0][1] else "blocks ") + parts[0]
    return "blocks " + ", ".join(parts[:-1]) + " and " + parts[-1]


def unmet(
    program: Program, needs: frozenset[Need], path: CompiledPath | None = None
) -> list[Problem]:
    """The problems of `program` for a consumer with `needs` (errors, each with its need).
    CALIBRATED_TOOLS is judged on the compiled path (`path`, required for that need)."""
    problems: list[Problem] = []
    if Need.SPINDLE_SPEEDS in needs:
        problems += _spindle_speeds(program)
    if Need.CALIBRATED_TOOLS in needs:
        assert path is not None, "calibrated tools are judged on the compiled path"
        problems += _calibrated_tools(path)
    return problems


def _spindle_speeds(program: Program) -> list[Problem]:
    users: dict[int, list[int]] = defaultdict(list)
    for number, block in enumerate(program.blocks, start=1):
        tool = block.tool_number
        if tool is not None and 1 <= tool <= 24:
            users[tool].append(number)
    problems = []
    for tool, numbers in sorted(users.items()):
        entry = program.block0.tool(tool)
        where = blocks_text(numbers)
        if entry is None:
            field, message = (
                f"TOOL {tool}",
                f"tool {tool} is used in {where} but is not in the tool table; add it with "
                "its RPM (the control makes an emergency stop when a tool without RPM is used)",
            )
        elif entry.rpm is None:
            field, message = (
                f"TOOL {tool} RPM",
                f"tool {tool} has no RPM and is used in {where}; the control makes an "
                "emergency stop when a tool without RPM is used (60 to 4000, or -60 to -4000 "
                "to run in reverse)",
            )
        else:
            continue
        problems.append(
            Problem(0, field, Severity.ERROR, message, Rule.TOOL_NO_RPM, Need.SPINDLE_SPEEDS)
        )
    return problems


def _calibrated_tools(path: CompiledPath) -> list[Problem]:
    """Tools without TCAL that move down in Z (a 2-axis program never does)."""
    users: dict[int, list[int]] = defaultdict(list)
    known = {n for n, t in path.tools.items() if t.tcal is not None}
    # The tools a motion can be made with: the first, and those of the TOOL rows, which a
    # placement does not change (each piece read once). All calibrated, there is nothing to
    # find, and the motions of a 10^5-line file need not be walked (0.1 s).
    in_spindle = {path.initial_tool}
    for piece in pieces(path.root):
        rows = piece.rows
        in_spindle.update(rows["value"][rows["op"] == Op.TOOL].tolist())
    if in_spindle <= known | {0}:
        return []
    calibrated = np.array(sorted(known), dtype=np.int64)
    for m in motions(path):
        down = m.rows["z"] < m.z0
        uncalibrated = (m.tool != 0) & ~np.isin(m.tool, calibrated)
        found = down & uncalibrated
        for tool, block in zip(
            m.tool[found].tolist(), m.rows["block"][found].tolist(), strict=True
        ):
            users[tool].append(block)
    return [
        Problem(
            0,
            f"TOOL {tool} TCAL",
            Severity.ERROR,
            f"tool {tool} is not calibrated (TCAL ****) and moves down in Z in "
            f"{blocks_text(numbers)}; Z words that include each tool's TCAL cannot place its "
            "tip: calibrate it in Data Block 0",
            Rule.TOOL_NO_TCAL,
            Need.CALIBRATED_TOOLS,
        )
        for tool, numbers in sorted(users.items())
    ]
