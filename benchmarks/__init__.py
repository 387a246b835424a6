"""Benchmarks (not part of the test run); `reference` is also the yardstick of a CI accuracy test."""
