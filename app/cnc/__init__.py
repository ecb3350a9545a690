"""The pure core: program model, validation, interpreter, tool path, emitters.

Nothing here imports Flask, a database or serial code (tests/test_layering.py checks).
"""
