"""Stock-removal simulation and verify: the finished part from the tool path.

segments.py  the tool path as numpy segment arrays (the one adapter from the Toolpath)
stock.py     the stock and the height-map grid
sweep.py     the vectorised sweep of each tool over the grid
programmed.py what the program asks for (the one adapter from the blocks)
verify.py    gouges, rest material, hole depths and crashes, per block
mesh.py      STL of the simulated part          image.py  PNG picture of it
"""
