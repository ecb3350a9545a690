"""Emitters: pure functions of a Toolpath (and options) to bytes or text."""
