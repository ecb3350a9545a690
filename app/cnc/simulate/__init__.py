"""Stock-removal simulation and verify: the finished part from the compiled tool path.

segments.py   a compiled piece's moves as numpy segment arrays (the one reader of MOVE rows)
placements.py the compiled path as groups of one piece placed at several offsets (LOOPs)
stock.py      the stock and the height-map grid
cells.py      which cells a segment's tool reaches: runs of cells, or exact (segment, cell) pairs
sweep.py      the simulation: groups folded into the height map, stamps for repeated pieces
programmed.py what the program asks for (the compiled holes and the plans mill spans keep)
verify.py     gouges, rest material, hole depths and crashes, per block
mesh.py       STL of the simulated part          image.py  PNG picture of it
"""
