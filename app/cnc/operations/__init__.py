"""The operations beyond drilling and milling a modern conversational control offers
(issue 33): HELIX (helical entry and boring), THREAD MILL, FACE and ENGRAVE, each a
block kind (app/cnc/blocks.py) whose planner is here: blocks in, moves (helical arcs
among them) out."""
