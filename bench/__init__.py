"""Benchmarks and the load test: see docs/benchmarks.md and docs/load.md."""
